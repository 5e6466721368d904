"""The joint library of the paper (Table 1, secs. 3 and 6).

Each function is a thin wrapper that writes the constraints as expressions and hands
them to :meth:`Model.add_constraint`; the loads come from the one general mechanism
(Lagrange's prescription, eq. 26). Constraint names are ``<joint>.<suffix>``; calling
two functions with the same joint name groups their constraints into one joint.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .bodies import Body, Point
from ..errors import ModelError
from .model import Model
from .rotations import unit_vector

E = [unit_vector(1), unit_vector(2), unit_vector(3)]


def _unit(v, what: str) -> ca.DM:
    a = np.asarray(v, dtype=float).reshape(3)
    n = np.linalg.norm(a)
    if not np.isfinite(n) or n == 0:
        raise ModelError(f"{what} must be a finite non-zero 3-vector, got {v!r}")
    return ca.DM(a / n)


def _complement(n: ca.DM) -> tuple[ca.DM, ca.DM]:
    """Two unit vectors completing ``n`` to a right-handed orthonormal basis ``(a1, a2, n)``."""
    a = np.asarray(n).ravel()
    k = int(np.argmax(np.abs(a)))
    # The next fixed basis vector, made normal to n (E3 -> E1, E2; E1 -> E2, E3).
    a1 = np.eye(3)[(k + 1) % 3]
    a1 = a1 - a1.dot(a) * a
    a1 /= np.linalg.norm(a1)
    return ca.DM(a1), ca.DM(np.cross(a, a1))


def ball_and_socket(model: Model, name: str, point: Point, other: Point | None = None, anchor=(0.0, 0.0, 0.0)) -> None:
    """``E_k . v_P = 0`` (to ground at ``anchor``) or ``E_k . v_C1 - E_k . v_C2 = 0`` (sec. 6).

    Loads: ``F_c = sum lambda_k E_k`` at ``X_P`` (and minus it on the other body), no moment.
    """
    if other is None:
        a = ca.DM(np.asarray(anchor, dtype=float).reshape(3))
        for k in range(3):
            model.add_constraint(
                f"{name}.v{k + 1}", ca.dot(E[k], point.v), joint=name,
                position=ca.dot(E[k], point.position - a), point=point,
            )
    else:
        if other.body is point.body:
            raise ModelError(f"joint '{name}': a ball-and-socket needs points of two different bodies")
        for k in range(3):
            model.add_constraint(
                f"{name}.v{k + 1}", ca.dot(E[k], point.v) - ca.dot(E[k], other.v), joint=name,
                position=ca.dot(E[k], point.position - other.position), point=point,
            )
        model.joints[name].points.setdefault(other.body.name, other)


def revolute(model: Model, name: str, point: Point, axis=(0, 0, 1), anchor=(0.0, 0.0, 0.0), body_axis=None) -> None:
    """Revolute joint to ground about the fixed ``axis`` through ``anchor`` (sec. 3.1).

    Constraints ``E_k . v_A = 0`` and ``a_1 . omega = 0``, ``a_2 . omega = 0`` with
    ``a_1, a_2`` normal to the axis (``E1, E2`` for ``E3``). Loads ``F_c = sum lambda_k E_k``
    at ``X_A``, ``M_c = lambda_4 a_1 + lambda_5 a_2`` (eq. 15). ``body_axis`` (body basis,
    default ``axis``) is the body's direction that stays on the axis; it gives the
    position form ``(Q n_b) . (a_i x n) = 0`` of the moment constraints.
    """
    n = _unit(axis, f"joint '{name}': axis")
    nb = n if body_axis is None else _unit(body_axis, f"joint '{name}': body_axis")
    body = point.body
    ball_and_socket(model, name, point, anchor=anchor)
    for k, a in enumerate(_complement(n)):
        model.add_constraint(
            f"{name}.w{k + 1}", ca.dot(a, body.omega), joint=name,
            position=ca.dot(body.Q @ nb, ca.cross(a, n)),
        )


def sliding_contact(model: Model, name: str, point: Point, normal=(0, 0, 1), rate=0.0, height: float | None = 0.0, position=None) -> None:
    """Sliding contact ``n . v_P = f(t)`` (sec. 3.3): ``F_c = lambda n`` at ``X_P``, ``M_c = 0``.

    For a fixed plane (``rate = 0``) the position form is ``n . x_P - height``; for a
    moving surface pass ``position`` (``phi(q, t)``) or None.
    """
    n = _unit(normal, f"joint '{name}': normal")
    if position is None and height is not None and isinstance(rate, (int, float)) and rate == 0:
        position = ca.dot(n, point.position) - height
    model.add_constraint(f"{name}.n", ca.dot(n, point.v) - rate, joint=name, position=position, point=point)


def rolling_contact(model: Model, name: str, point: Point, surface_velocity=(0.0, 0.0, 0.0), height: float | None = 0.0) -> None:
    """Rolling without slipping ``E_k . v_P = E_k . v_s`` (sec. 3.3).

    ``F_c = sum lambda_k E_k`` at ``X_P`` (normal force plus static friction), ``M_c = 0``.
    Only the normal direction ``E3`` is holonomic (``E3 . x_P = height`` for a fixed plane).
    """
    vs = ca.SX(surface_velocity) if isinstance(surface_velocity, ca.SX) else ca.DM(np.asarray(surface_velocity, dtype=float).reshape(3))
    for k in range(3):
        pos = None
        if k == 2 and height is not None and not isinstance(vs, ca.SX) and float(vs[2]) == 0.0:
            pos = ca.dot(E[2], point.position) - height
        model.add_constraint(
            f"{name}.v{k + 1}", ca.dot(E[k], point.v) - ca.dot(E[k], vs), joint=name, position=pos, point=point,
        )


def sliding_cylinder(model: Model, name: str, body: Body, height: float = 0.0) -> None:
    """Cylinder on a smooth plane (sec. 3.2): ``E3 . vbar = 0``, ``(e3 x E3) . omega = 0``.

    ``F_c = lambda_1 E3`` at the center of mass, ``M_c = lambda_2 (e3 x E3)`` (eq. 17).
    Position forms: ``E3 . xbar - height`` and ``e3 . E3`` (the axis stays horizontal).
    """
    model.add_constraint(f"{name}.normal", ca.dot(E[2], body.vbar), joint=name,
                         position=body.xbar[2] - height, point=body.com)
    model.add_constraint(f"{name}.tilt", ca.dot(ca.cross(body.e(3), E[2]), body.omega), joint=name,
                         position=ca.dot(body.e(3), E[2]))


def driven_axis(model: Model, name: str, body: Body, rate, index: int = 1, rate_integral=None, initial_angle: float | None = None) -> None:
    """Prescribed angle rate ``g^i . omega = Omega(t)`` (sec. 3.4), e.g. a motor-driven shaft.

    ``M_c = lambda g^i``; its power is ``lambda Omega`` (eq. 27). Give
    ``rate_integral`` (``int_0^t Omega``, an expression of ``model.t``) and
    ``initial_angle`` to get the position form ``a_i - a_i(0) - int Omega``.
    """
    gi = body.dual_euler_basis()[index - 1]
    pos = None
    if rate_integral is not None and initial_angle is not None:
        pos = body.rotation_parameters[index - 1] - initial_angle - rate_integral
    model.add_constraint(f"{name}.drive", ca.dot(gi, body.omega) - rate, joint=name, position=pos)


def fixed_angle(model: Model, name: str, body: Body, index: int, value: float | None = None, suffix: str = "lock") -> None:
    """Fixed Euler angle: ``g^i . omega = 0`` (sec. 3.4, sec. 6): ``M_c = lambda g^i``.

    With ``value``, the position form is ``a_i - value``.
    """
    gi = body.dual_euler_basis()[index - 1]
    pos = None if value is None else body.rotation_parameters[index - 1] - value
    model.add_constraint(f"{name}.{suffix}", ca.dot(gi, body.omega), joint=name, position=pos)
