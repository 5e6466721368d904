"""Checks of what a model is built from, at the call that receives it (names in every message).

Used by :mod:`.model` and :mod:`.joints`: an Euler-angle index, a rate or load given as a
number or a CasADi expression (not a Python function), a point or body that belongs to the
model, and no NaN or inf written into an expression.
"""
from __future__ import annotations

import math
import numbers

import casadi as ca

from ..errors import ModelError


def angle_index(index, body, joint: str) -> int:
    """``index`` of an Euler angle of ``body`` (1, 2 or 3), for joint ``joint``."""
    if isinstance(index, bool) or not isinstance(index, numbers.Integral) or not 1 <= int(index) <= 3:
        names = getattr(body.rotation, "parameter_names", ("psi", "theta", "phi"))
        raise ModelError(
            f"joint '{joint}': index must be 1, 2 or 3 (the Euler angle of body '{body.name}': "
            f"1 = {names[0]}, 2 = {names[1]}, 3 = {names[2]}), got {index!r}")
    return int(index)


def nonfinite_constants(expr) -> list[float]:
    """NaN or inf numbers written into an SX expression (as constants of its graph)."""
    if isinstance(expr, ca.DM):
        return [v for v in expr.full().ravel().tolist() if not math.isfinite(v)]
    if not isinstance(expr, ca.SX):
        return []
    f = ca.Function("constants", ca.symvar(expr), [expr])
    return [f.instruction_constant(k) for k in range(f.n_instructions())
            if f.instruction_id(k) == ca.OP_CONST and not math.isfinite(f.instruction_constant(k))]


def check_finite(expr, what: str) -> None:
    """A :class:`ModelError` naming ``what`` if ``expr`` has a NaN or inf written into it."""
    bad = nonfinite_constants(expr)
    if bad:
        raise ModelError(f"{what} contains {', '.join(sorted({repr(v) for v in bad}))}: a NaN or inf was written "
                         "into the expression (often a parameter that is not finite, or 0/0). Fix the expression")


def scalar_expression(value, what: str, hint: str = "e.g. 2.0 + 0.5 * ca.sin(model.t)") -> ca.SX:
    """A number or a scalar CasADi SX expression (of ``model.t``, coordinates, inputs); else a clear error."""
    if callable(value) and not isinstance(value, (ca.SX, ca.MX, ca.DM)):
        raise ModelError(f"{what} is a Python function; give a number or a CasADi expression of model.t "
                         f"instead ({hint}); a function of t cannot be differentiated into the constraint")
    if isinstance(value, ca.MX):
        raise ModelError(f"{what} is an MX expression; write it with SX symbols (model.t, coordinates, inputs)")
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, ca.SX, ca.DM)):
        try:
            value = float(value)   # a NumPy scalar or a 0-d array
        except (TypeError, ValueError):
            raise ModelError(f"{what} must be a number or a CasADi SX expression ({hint}), "
                             f"got {type(value).__name__}") from None
    if isinstance(value, numbers.Real):
        if not math.isfinite(value):
            raise ModelError(f"{what} is {value!r}: give a finite number or an expression")
        return ca.SX(value)
    sx = ca.SX(value)
    if sx.shape != (1, 1):
        raise ModelError(f"{what} must be a scalar, got shape {sx.shape}")
    check_finite(sx, what)
    return sx


def member_body(model, body, what: str) -> None:
    """``body`` (a body or a point's body) must be one of ``model``'s bodies (the same object)."""
    name = getattr(body, "name", None)
    if model.bodies.get(name) is not body:
        where = (f"model '{model.name}' has a different body named '{name}'" if name in model.bodies
                 else f"body '{name}' is not in model '{model.name}'")
        raise ModelError(f"{what}: {where} (its bodies: {', '.join(model.bodies) or 'none'}). "
                         "Use a point or body made by this model's add_body")


def check_constraint_values(eqs, G, e, phi, where: str = "at the initial state") -> None:
    """A :class:`ModelError` naming every constraint whose gradient, ``e`` or position form is NaN or inf."""
    import numpy as np

    G, e, phi = np.asarray(G, dtype=float), np.asarray(e, dtype=float).ravel(), np.asarray(phi, dtype=float).ravel()
    bad = []
    for k, name in enumerate(eqs.constraint_names):
        parts = [what for what, ok in (("its gradient", np.all(np.isfinite(G[k]))), ("e", np.isfinite(e[k]))) if not ok]
        if k in eqs.holonomic and not np.isfinite(phi[eqs.holonomic.index(k)]):
            parts.append("its position form phi")
        if parts:
            bad.append(f"'{name}' ({', '.join(parts)})")
    if bad:
        raise ModelError(
            f"constraint(s) {', '.join(bad)} evaluate to NaN or inf {where}: a NaN or inf in the expression (or in "
            "a parameter or input that feeds it), or a division by zero at this state. Fix the expression or the state")


def input_values(eqs, inputs, t: float) -> "np.ndarray":
    """Input values for ``eqs`` (None: zeros): the model's number of finite numbers, else a clear error."""
    import numpy as np

    names = list(eqs.model.inputs)
    if inputs is None:
        return np.zeros(len(names))
    try:
        w = np.asarray(inputs, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"inputs at t = {t:g} must be {len(names)} numbers ({', '.join(names) or 'the model has none'}), "
                         f"got {inputs!r}") from None
    if w.size != len(names):
        raise ModelError(f"inputs at t = {t:g} have {w.size} value(s); model '{eqs.model.name}' has {len(names)} "
                         f"input(s): {', '.join(names) or 'none'}. Give one value per input, in this order")
    w = w.reshape(len(names))
    bad = [n for n, v in zip(names, w) if not np.isfinite(v)]
    if bad:
        raise ModelError(f"input(s) {', '.join(repr(b) for b in bad)} are not finite at t = {t:g}: give finite values")
    return w
