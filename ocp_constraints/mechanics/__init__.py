"""Mechanics: rotations, bodies, constraints and joints, the model, its equations and consistent states.

The bottom layer: it imports nothing of the toolkit but :mod:`ocp_constraints.errors`.
"""
