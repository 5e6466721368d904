"""The spatial joints, each to ground or between two bodies (paper Table 1 and sec. 6).

Every joint is a few scalar constraints handed to :meth:`Model.add_constraint`; its loads
come from the one general mechanism (Lagrange's prescription, eq. 26), never from a
special path in the solver. A joint connects the material point ``point`` (``X_C1`` on
the *body*) to the *base*: the ground (``other=None``; the joint's ground point is
``anchor``) or the material point ``other`` (``X_C2`` on a second body). Directions
written "in the base basis" are the fixed basis ``E_k`` for the ground and the body basis
``e_k = Q_2 E_k`` of the second body (they turn with it); "in the body basis" means the
basis of ``point``'s body. Two-body constraints read ``f . v_C1 - f . v_C2 + ... = 0``
(sec. 6) and so give equal and opposite loads (Newton's third law).

The building blocks, each with a position form ``phi(q)`` (``d(phi)/dt = pi`` on the
constraint manifold) so that simulations and optimal control keep them at position level:

* ``v1, v2, v3``: ``E_k . (v_C1 - v_C2) = 0``; force ``lambda_k E_k`` (fixed basis) at
  ``X_C1`` on the body, the opposite on the base. Position form ``E_k . (x_C1 - x_C2)``.
* ``n1, n2`` / ``n`` (base-fixed direction ``d = Q_2 a``):
  ``d . (v_C1 - v_C2) + omega_2 . (d x (x_C1 - x_C2)) = 0``, the time derivative of
  ``d . (x_C1 - x_C2)``; force ``lambda d`` at ``X_C1`` on the body, ``-lambda d`` on the base
  (reported at ``X_C2`` together with the moment of the offset, so it acts along the same line).
* ``w1, w2, w3`` / ``w``: ``(omega_1 - omega_2) . d = 0``; moment ``lambda d`` on the body,
  ``-lambda d`` on the base (the two-body form of the paper's ``E_1 . omega = 0``, eq. 14).

Use :meth:`Model.describe` to list every multiplier ``<joint>.<suffix>.lambda`` of a model
with the force or moment component it is.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .bodies import Point
from ..errors import ModelError
from .joint_maps import record
from .model import Model
from .rotations import unit_vector

E = [unit_vector(1), unit_vector(2), unit_vector(3)]


def _vec3(v, what: str) -> np.ndarray:
    try:
        return np.asarray(v, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be 3 numbers, got {v!r}") from None


def _unit(v, what: str) -> ca.DM:
    a = _vec3(v, what)
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


def _rotation(R, what: str) -> ca.DM:
    if R is None:
        return ca.DM.eye(3)
    a = np.asarray(R, dtype=float)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)) or not np.allclose(a @ a.T, np.eye(3), atol=1e-9) \
            or np.linalg.det(a) < 0:
        raise ModelError(f"{what} must be a 3x3 rotation matrix (orthogonal, det +1), got {R!r}")
    return ca.DM(a)


def _fmt(v) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in np.asarray(v, dtype=float).ravel()) + ")"


@dataclass(eq=False)
class _Pair:
    """The two sides of a joint: ``point`` on the body, and the ground or ``other`` (the base)."""

    name: str
    point: Point
    other: Point | None
    Q2: ca.SX | ca.DM          # base basis in the fixed basis (identity for the ground)
    x2: ca.SX | ca.DM          # the base's point of the joint (anchor or X_C2)

    @property
    def body(self):
        return self.point.body

    @property
    def frame(self) -> str:
        return "fixed basis" if self.other is None else f"basis of body '{self.other.body.name}', turning with it"

    @property
    def opposite(self) -> str:
        if self.other is None:
            return ""
        return f"; the opposite on '{self.other.body.name}' (Newton's third law)"

    def rel_velocity(self, d) -> ca.SX:
        """``d . (v_C1 - v_C2)``."""
        return ca.dot(d, self.point.v) - (0 if self.other is None else ca.dot(d, self.other.v))

    def rel_omega(self, d) -> ca.SX:
        """``d . (omega_1 - omega_2)``."""
        return ca.dot(d, self.body.omega) - (0 if self.other is None else ca.dot(d, self.other.body.omega))


def _pair(name: str, point: Point, other: Point | None, anchor) -> _Pair:
    if other is None:
        a = ca.DM.zeros(3, 1) if anchor is None else ca.DM(_vec3(anchor, f"joint '{name}': anchor"))
        if not np.all(np.isfinite(np.asarray(a))):
            raise ModelError(f"joint '{name}': anchor must be 3 finite numbers, got {anchor!r}")
        return _Pair(name, point, None, ca.DM.eye(3), a)
    if anchor is not None:
        raise ModelError(f"joint '{name}': anchor is for a joint to ground; between two bodies the joint "
                         f"acts at the given points ({point.label}, {other.label})")
    if other.body is point.body:
        raise ModelError(f"joint '{name}': a joint between two bodies needs points of two different bodies, "
                         f"got {point.label} and {other.label}")
    return _Pair(name, point, other, other.body.Q, other.position)


def _add(model: Model, pair: _Pair, suffix: str, expression, position, note: str) -> None:
    cname = f"{pair.name}.{suffix}"
    model.add_constraint(cname, expression, joint=pair.name, position=position, point=pair.point)
    model.constraint_notes[cname] = note


# -- building blocks ----------------------------------------------------------------------
def _pin(model: Model, pair: _Pair) -> None:
    """``E_k . (v_C1 - v_C2) = 0`` (Table 1, sec. 6): the two points stay together."""
    for k in range(3):
        _add(model, pair, f"v{k + 1}", pair.rel_velocity(E[k]), ca.dot(E[k], pair.point.position - pair.x2),
             f"force component along E{k + 1} (fixed basis) on '{pair.body.name}' at {pair.point.label}"
             + pair.opposite)


def _slide(model: Model, pair: _Pair, suffix: str, a: ca.DM) -> None:
    """``d . (v_C1 - v_C2) + omega_2 . (d x (x_C1 - x_C2)) = 0`` with ``d = Q_2 a`` fixed in the base."""
    d = pair.Q2 @ a
    r = pair.point.position - pair.x2
    expr = pair.rel_velocity(d)
    if pair.other is not None:
        expr = expr + ca.dot(ca.cross(d, r), pair.other.body.omega)
    where = "" if pair.other is None else f" (on '{pair.other.body.name}' it acts along the same line, " \
        f"reported at {pair.other.label} with the moment of the offset)"
    _add(model, pair, suffix, expr, ca.dot(d, r),
         f"force component along {_fmt(a)} ({pair.frame}) on '{pair.body.name}' at {pair.point.label}"
         + pair.opposite + where)


def _turn(model: Model, pair: _Pair, suffix: str, d, position, what: str) -> None:
    """``(omega_1 - omega_2) . d = 0``: moment ``lambda d`` on the body, ``-lambda d`` on the base."""
    _add(model, pair, suffix, pair.rel_omega(d), position,
         f"moment component on '{pair.body.name}' about {what}" + pair.opposite)


def _keep_axis(model: Model, pair: _Pair, n: ca.DM, nb: ca.DM) -> None:
    """Relative rotation about ``n`` only: ``(omega_1 - omega_2) . (Q_2 c_k) = 0`` for ``c_1, c_2`` normal to ``n``.

    Position form ``(Q_1 n_b) . (Q_2 (c_k x n))``: its rate is the constraint where ``Q_1 n_b = Q_2 n``.
    """
    n_body = pair.body.Q @ nb
    for k, c in enumerate(_complement(n)):
        _turn(model, pair, f"w{k + 1}", pair.Q2 @ c, ca.dot(n_body, pair.Q2 @ ca.cross(c, n)),
              f"{_fmt(c)} ({pair.frame}), normal to the axis {_fmt(n)}")


def _lock_rotation(model: Model, pair: _Pair, R0: ca.DM) -> None:
    """No relative rotation: ``(omega_1 - omega_2) . (Q_2 E_k) = 0``, ``k = 1, 2, 3``.

    ``R0`` is the body basis in the base basis (``Q_1 = Q_2 R0``). Position form: the axial
    vector of the relative rotation's skew part, ``(Q_1 R0^T E_j) . (Q_2 E_k)`` antisymmetrized.
    """
    A = pair.body.Q @ R0.T
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        phi = 0.5 * (ca.dot(A[:, i], pair.Q2[:, j]) - ca.dot(A[:, j], pair.Q2[:, i]))
        _turn(model, pair, f"w{k + 1}", pair.Q2[:, k], phi, f"the base's e{k + 1} ({pair.frame})")


# -- the joints ------------------------------------------------------------------------------
def ball_and_socket(model: Model, name: str, point: Point, other: Point | None = None, anchor=None) -> None:
    """Ball-and-socket (3 DOF): ``E_k . v_P = 0`` to ground at ``anchor`` (default origin), or
    ``E_k . v_C1 - E_k . v_C2 = 0`` between two bodies (sec. 6).

    Multipliers ``v1, v2, v3``: force components along ``E_k`` (fixed basis) at ``X_P`` (and
    minus them on the other body); no moment.
    """
    _pin(model, _pair(name, point, other, anchor))


def revolute(model: Model, name: str, point: Point, axis=(0, 0, 1), anchor=None, body_axis=None, *,
             other: Point | None = None) -> None:
    """Revolute joint (1 DOF) about ``axis`` through the joint point (sec. 3.1, eqs. 14-15).

    ``axis`` is in the base basis (fixed basis to ground, ``other``'s body basis between two
    bodies); ``body_axis`` (body basis, default ``axis``) is the body's direction that stays
    on it. Multipliers ``v1, v2, v3``: force components along ``E_k`` (fixed basis) at
    ``X_A``; ``w1, w2``: moment components about ``a_1, a_2`` normal to the axis, fixed in the
    base (``E1, E2`` for ``axis = E3``: eq. 15). Between two bodies, the opposite loads act
    on ``other``'s body.
    """
    n = _unit(axis, f"joint '{name}': axis")
    nb = n if body_axis is None else _unit(body_axis, f"joint '{name}': body_axis")
    pair = _pair(name, point, other, anchor)
    _pin(model, pair)
    _keep_axis(model, pair, n, nb)
    record(model, name, "revolute", point, other, pair.x2 if other is None else None, np.asarray(n).ravel(),
           body_axis=np.asarray(nb).ravel())


def universal(model: Model, name: str, point: Point, other: Point | None = None, *, axis=(1, 0, 0),
              body_axis=(0, 1, 0), anchor=None) -> None:
    """Universal (Hooke) joint (2 DOF): a cross whose arm ``a`` (``axis``, base basis) is fixed in
    the base and arm ``b`` (``body_axis``, body basis) in the body; ``a`` and ``b`` must be
    perpendicular in the assembled state.

    Constraints ``v1, v2, v3`` as for the ball-and-socket and
    ``w``: ``(omega_1 - omega_2) . (a x b) = 0`` (position form ``-a . b``): moment
    ``lambda (a x b)``, normal to both arms (the relative rotations about ``a`` and ``b`` are free).
    """
    a0 = _unit(axis, f"joint '{name}': axis")
    b0 = _unit(body_axis, f"joint '{name}': body_axis")
    pair = _pair(name, point, other, anchor)
    _pin(model, pair)
    a, b = pair.Q2 @ a0, pair.body.Q @ b0
    _turn(model, pair, "w", ca.cross(a, b), -ca.dot(a, b),
          f"a x b, a = {_fmt(a0)} ({pair.frame}), b = {_fmt(b0)} (basis of body '{pair.body.name}')")


def point_on_line(model: Model, name: str, point: Point, other: Point | None = None, *, axis=(0, 0, 1),
                  anchor=None) -> None:
    """Point on a line (4 DOF): ``X_C1`` stays on the line through the anchor (or ``X_C2``) along
    ``axis`` (base basis).

    Multipliers ``n1, n2``: force components along ``a_1, a_2`` normal to the axis (base
    basis); no moment. Closes a planar loop without redundancy (e.g. a four-bar's last pin,
    whose other three components the loop's revolute joints already impose).
    """
    n = _unit(axis, f"joint '{name}': axis")
    pair = _pair(name, point, other, anchor)
    for k, a in enumerate(_complement(n)):
        _slide(model, pair, f"n{k + 1}", a)


def cylindrical(model: Model, name: str, point: Point, other: Point | None = None, *, axis=(0, 0, 1),
                anchor=None, body_axis=None) -> None:
    """Cylindrical joint (2 DOF): slides along and turns about ``axis`` (base basis) through the
    anchor (or ``X_C2``); ``body_axis`` (body basis, default ``axis``) stays parallel to it.

    Multipliers ``n1, n2``: force components along ``a_1, a_2`` normal to the axis (base
    basis) at ``X_C1``; ``w1, w2``: moment components about ``a_1, a_2``.
    """
    n = _unit(axis, f"joint '{name}': axis")
    nb = n if body_axis is None else _unit(body_axis, f"joint '{name}': body_axis")
    pair = _pair(name, point, other, anchor)
    for k, a in enumerate(_complement(n)):
        _slide(model, pair, f"n{k + 1}", a)
    _keep_axis(model, pair, n, nb)


def prismatic(model: Model, name: str, point: Point, other: Point | None = None, *, axis=(0, 0, 1),
              anchor=None, relative_rotation=None) -> None:
    """Prismatic joint (1 DOF): ``X_C1`` slides along ``axis`` (base basis) through the anchor (or
    ``X_C2``) without turning relative to the base.

    ``relative_rotation`` is the body basis in the base basis, ``Q_1 = Q_2 R0`` (default the
    identity). Multipliers ``n1, n2``: force components along ``a_1, a_2`` normal to the axis
    (base basis) at ``X_C1``; ``w1, w2, w3``: moment components about the base's ``e_1, e_2, e_3``
    (fixed ``E_k`` to ground).
    """
    n = _unit(axis, f"joint '{name}': axis")
    R0 = _rotation(relative_rotation, f"joint '{name}': relative_rotation")
    pair = _pair(name, point, other, anchor)
    for k, a in enumerate(_complement(n)):
        _slide(model, pair, f"n{k + 1}", a)
    _lock_rotation(model, pair, R0)
    record(model, name, "prismatic", point, other, pair.x2 if other is None else None, np.asarray(n).ravel(),
           R0=np.asarray(R0))


def planar(model: Model, name: str, point: Point, other: Point | None = None, *, normal=(0, 0, 1),
           anchor=None, body_normal=None) -> None:
    """Planar joint (3 DOF): ``X_C1`` stays in the plane through the anchor (or ``X_C2``) normal to
    ``normal`` (base basis) and the body turns only about the normal; ``body_normal`` (body
    basis, default ``normal``) stays parallel to it.

    Multipliers ``n``: force component along the normal at ``X_C1``; ``w1, w2``: moment
    components about ``a_1, a_2`` in the plane (base basis).
    """
    n = _unit(normal, f"joint '{name}': normal")
    nb = n if body_normal is None else _unit(body_normal, f"joint '{name}': body_normal")
    pair = _pair(name, point, other, anchor)
    _slide(model, pair, "n", n)
    _keep_axis(model, pair, n, nb)


def weld(model: Model, name: str, point: Point, other: Point | None = None, *, anchor=None,
         relative_rotation=None) -> None:
    """Weld (0 DOF): the body is fixed to the base; ``relative_rotation`` is the body basis in the
    base basis (``Q_1 = Q_2 R0``, default the identity).

    Multipliers ``v1, v2, v3``: force components along ``E_k`` (fixed basis) at ``X_C1``;
    ``w1, w2, w3``: moment components about the base's ``e_1, e_2, e_3`` (fixed ``E_k`` to ground).
    """
    R0 = _rotation(relative_rotation, f"joint '{name}': relative_rotation")
    pair = _pair(name, point, other, anchor)
    _pin(model, pair)
    _lock_rotation(model, pair, R0)
    record(model, name, "weld", point, other, pair.x2 if other is None else None, R0=np.asarray(R0))
