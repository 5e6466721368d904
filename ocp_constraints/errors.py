"""Errors raised by the toolkit: each names the offending thing and what to do."""
from __future__ import annotations


class OcpConstraintsError(Exception):
    """Base class of every error this toolkit raises on purpose."""


class ModelError(OcpConstraintsError, ValueError):
    """A body, point, constraint, load or parameter is ill-formed."""


class NonAffineConstraintError(ModelError):
    """A constraint expression is not affine in the velocities (paper eq. 25)."""


class RedundantConstraintsError(ModelError):
    """The constraint Jacobian is rank deficient: some constraints repeat others."""


class InconsistentStateError(ModelError):
    """Initial coordinates or speeds violate the constraints."""


class SceneError(OcpConstraintsError, ValueError):
    """A scene name, scene file or scene parameter is unusable."""


class SimulationError(OcpConstraintsError, RuntimeError):
    """A forward simulation stopped early; ``partial`` holds what was computed."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial
