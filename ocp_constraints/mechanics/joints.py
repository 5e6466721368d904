"""The joint library of the paper (Table 1, secs. 3 and 6).

Each function is a thin wrapper that writes the constraints as expressions and hands
them to :meth:`Model.add_constraint`; the loads come from the one general mechanism
(Lagrange's prescription, eq. 26). Constraint names are ``<joint>.<suffix>``; calling
two functions with the same joint name groups their constraints into one joint.

The spatial joints (ball-and-socket, revolute, universal, cylindrical, prismatic, planar,
weld, point on a line), each to ground or between two bodies, are in
:mod:`~ocp_constraints.mechanics.joints_spatial` and re-exported here; the contact and drive
constraints of sec. 3 are below. :meth:`Model.describe` lists every multiplier of a model
with the force or moment component it is.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .bodies import Body, Point
from .joints_spatial import (  # noqa: F401  (the spatial joints are part of this library)
    E, _fmt, _unit, ball_and_socket, cylindrical, planar, point_on_line, prismatic, revolute, universal, weld,
)
from ..errors import ModelError
from .model import Model
from .validate import angle_index, scalar_expression


def _note(model: Model, cname: str, text: str) -> None:
    model.constraint_notes[cname] = text


def sliding_contact(model: Model, name: str, point: Point, normal=(0, 0, 1), rate=0.0, height: float | None = 0.0, position=None) -> None:
    """Sliding contact ``n . v_P = f(t)`` (sec. 3.3): ``F_c = lambda n`` at ``X_P``, ``M_c = 0``.

    For a fixed plane (``rate = 0``) the position form is ``n . x_P - height``; for a
    moving surface pass ``position`` (``phi(q, t)``) or None. Multiplier ``n``: the normal force.
    """
    n = _unit(normal, f"joint '{name}': normal")
    rate = scalar_expression(rate, f"joint '{name}': rate", "e.g. 0.1 * ca.sin(model.t) for a moving surface")
    if position is None and height is not None and rate.is_zero():
        position = ca.dot(n, point.position) - height
    model.add_constraint(f"{name}.n", ca.dot(n, point.v) - rate, joint=name, position=position, point=point)
    _note(model, f"{name}.n", f"normal force: component along {_fmt(n)} (fixed basis) on '{point.body.name}' "
          f"at {point.label}")


def rolling_contact(model: Model, name: str, point: Point, surface_velocity=(0.0, 0.0, 0.0), height: float | None = 0.0) -> None:
    """Rolling without slipping ``E_k . v_P = E_k . v_s`` (sec. 3.3).

    ``F_c = sum lambda_k E_k`` at ``X_P`` (normal force plus static friction), ``M_c = 0``.
    Only the normal direction ``E3`` is holonomic (``E3 . x_P = height`` for a fixed plane).
    """
    if isinstance(surface_velocity, ca.SX):
        vs = surface_velocity
    else:
        try:
            vs = ca.DM(np.asarray(surface_velocity, dtype=float).reshape(3))
        except (TypeError, ValueError):
            raise ModelError(f"joint '{name}': surface_velocity must be 3 numbers or a 3x1 CasADi SX expression of "
                             f"model.t, got {type(surface_velocity).__name__}") from None
    for k in range(3):
        pos = None
        if k == 2 and height is not None and not isinstance(vs, ca.SX) and float(vs[2]) == 0.0:
            pos = ca.dot(E[2], point.position) - height
        model.add_constraint(
            f"{name}.v{k + 1}", ca.dot(E[k], point.v) - ca.dot(E[k], vs), joint=name, position=pos, point=point,
        )
        kind = "normal force" if k == 2 else "friction force"
        _note(model, f"{name}.v{k + 1}", f"{kind}: component along E{k + 1} (fixed basis) on "
              f"'{point.body.name}' at {point.label}")


def sliding_cylinder(model: Model, name: str, body: Body, height: float = 0.0) -> None:
    """Cylinder on a smooth plane (sec. 3.2): ``E3 . vbar = 0``, ``(e3 x E3) . omega = 0``.

    ``F_c = lambda_1 E3`` at the center of mass, ``M_c = lambda_2 (e3 x E3)`` (eq. 17).
    Position forms: ``E3 . xbar - height`` and ``e3 . E3`` (the axis stays horizontal).
    """
    model.add_constraint(f"{name}.normal", ca.dot(E[2], body.vbar), joint=name,
                         position=body.xbar[2] - height, point=body.com)
    model.add_constraint(f"{name}.tilt", ca.dot(ca.cross(body.e(3), E[2]), body.omega), joint=name,
                         position=ca.dot(body.e(3), E[2]))
    _note(model, f"{name}.normal", f"normal force along E3 (fixed basis) on '{body.name}' at its center of mass")
    _note(model, f"{name}.tilt", f"moment component about e3 x E3 (e3 of body '{body.name}') on '{body.name}'")


def _free_suffix(model: Model, name: str, suffix: str | None, default: str, index: int) -> str:
    """``suffix``, or ``default`` if ``<name>.<default>`` is free, else ``<default><index>``."""
    if suffix is not None:
        return suffix
    taken = {c.name for c in model.constraints}
    return default if f"{name}.{default}" not in taken else f"{default}{index}"


def driven_axis(model: Model, name: str, body: Body, rate, index: int = 1, rate_integral=None, initial_angle: float | None = None,
                suffix: str | None = None) -> None:
    """Prescribed angle rate ``g^i . omega = Omega(t)`` (sec. 3.4), e.g. a motor-driven shaft.

    ``M_c = lambda g^i``; its power is ``lambda Omega`` (eq. 27). Give
    ``rate_integral`` (``int_0^t Omega``, an expression of ``model.t``) and
    ``initial_angle`` to get the position form ``a_i - a_i(0) - int Omega``. The multiplier is
    ``<name>.drive``; a second drive in the same joint is ``<name>.drive<index>`` (or ``suffix``).
    """
    index = angle_index(index, body, name)
    rate = scalar_expression(rate, f"joint '{name}': rate Omega(t)")
    gi = body.dual_euler_basis()[index - 1]
    pos = None
    if rate_integral is not None and initial_angle is not None:
        pos = body.rotation_parameters[index - 1] - initial_angle - rate_integral
    cname = f"{name}.{_free_suffix(model, name, suffix, 'drive', index)}"
    model.add_constraint(cname, ca.dot(gi, body.omega) - rate, joint=name, position=pos)
    _note(model, cname, f"motor torque: moment component along g^{index} (dual Euler basis of body '{body.name}') "
          f"on '{body.name}'; power lambda Omega (eq. 27)")


def fixed_angle(model: Model, name: str, body: Body, index: int, value: float | None = None, suffix: str | None = None) -> None:
    """Fixed Euler angle: ``g^i . omega = 0`` (sec. 3.4, sec. 6): ``M_c = lambda g^i``.

    With ``value``, the position form is ``a_i - value``. The multiplier is ``<name>.lock``; a
    second fixed angle in the same joint is ``<name>.lock<index>`` (or ``suffix``).
    """
    index = angle_index(index, body, name)
    gi = body.dual_euler_basis()[index - 1]
    pos = None if value is None else body.rotation_parameters[index - 1] - value
    cname = f"{name}.{_free_suffix(model, name, suffix, 'lock', index)}"
    model.add_constraint(cname, ca.dot(gi, body.omega), joint=name, position=pos)
    _note(model, cname, f"moment component along g^{index} (dual Euler basis of body '{body.name}') on '{body.name}'")
