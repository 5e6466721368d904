"""Biomechanics: OpenSim files and models, gait inverse dynamics and knee contact loads
(uses mechanics, dynamics, output)."""
