"""The pieces of an optimal-control problem's objective and constraints, as :class:`.problem.OptimalControlProblem`
keeps them: expressions of the model's quantities with their weights or bounds."""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ModelError


@dataclass
class IntegralTerm:
    """``weight * int expression dt`` (a Lagrange term)."""
    label: str
    expression: ca.SX
    weight: float


@dataclass
class TerminalTerm(IntegralTerm):
    """``weight * expression`` at the final time (a Mayer term): the same fields, read at one point."""


@dataclass
class PathConstraint:
    label: str
    expression: ca.SX
    lower: float
    upper: float
    # The row's typical magnitude where its bounds do not say it (a friction cone's are 0): the NLP's row is
    # divided by the larger of this and its largest finite bound (transcription_elements.path_scale).
    scale: float = 1.0


def finite(value, what: str) -> float:
    """``value`` as a float, or a :class:`ModelError` naming ``what`` (a NaN weight reaches IPOPT as
    'Invalid_Number_Detected' after 0 iterations, which names nothing)."""
    v = float(value)
    if not np.isfinite(v):
        raise ModelError(f"the {what} must be a finite number, got {value!r}")
    return v
