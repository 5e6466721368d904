"""Dynamics: forward simulation, pointwise inverse dynamics and the trajectory they return (uses mechanics)."""
