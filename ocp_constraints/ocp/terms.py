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


def reference_expression(reference, t: ca.SX, name: str) -> ca.SX:
    """``reference(t)`` for CasADi's symbolic time ``t`` (:meth:`.problem.OptimalControlProblem.track`), or a
    :class:`ModelError` that says what to write instead. A NumPy or SciPy function of the symbol either raises or,
    as SciPy's ``CubicSpline`` does, returns NaN, which reached IPOPT as 'Invalid_Number_Detected' after 0
    iterations, naming nothing."""
    advice = (f"track('{name}', reference): reference(t) must be a scalar expression of CasADi's symbolic time t, built "
              f"with CasADi operations (ca.sin(t), ca.if_else(...)); NumPy and SciPy functions such as scipy's CubicSpline "
              f"or interp1d do not take a CasADi symbol. For samples (times, values): ca.pw_lin(t, ca.DM(times), "
              f"ca.DM(values)), linear between them")
    try:
        value = ca.SX(reference(t))
    except Exception as exc:        # noqa: BLE001 - any failure of the user's function is this mistake
        raise ModelError(f"{advice}; calling it raised {type(exc).__name__}: {exc}") from exc
    if value.numel() != 1:
        raise ModelError(f"{advice}; it returned {value.size1()} x {value.size2()} values")
    constant = None if ca.depends_on(value, t) else float(ca.DM(ca.evalf(value)))
    if constant is not None and not np.isfinite(constant):
        raise ModelError(f"{advice}; it returned {constant}")
    return value
