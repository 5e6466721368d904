"""Constraints written as CasADi expressions, and Lagrange's prescription for their loads.

A scalar constraint on one or two bodies is ``pi = f . v_C + h . omega + e = 0``
(paper eq. 25), written by the user in terms of point velocity symbols ``P.v`` and
angular velocity symbols ``body.omega``. The toolkit takes the gradients itself:
``F_c = lambda d(pi)/d(v_C)`` acting at ``X_C`` and ``M_c = lambda d(pi)/d(omega)``
(paper eq. 26). A joint is a named group of scalar constraints that share one
application point per body; constraints written at another point of the same body are
moved there by eq. (32).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

from .bodies import Body, Point
from ..errors import ModelError, NonAffineConstraintError


@dataclass(eq=False)
class BodyShare:
    """What one constraint does to one body: ``F_c = lambda f`` at ``point``, ``M_c = lambda h``."""

    body: Body
    point: Point
    f: ca.SX
    h: ca.SX

    @property
    def has_force(self) -> bool:
        return self.f.nnz() > 0

    @property
    def has_moment(self) -> bool:
        return self.h.nnz() > 0


@dataclass(eq=False)
class Constraint:
    """A scalar constraint ``pi = 0`` with its derived prescription.

    Attributes
    ----------
    name
        Full name, used as ``<name>.lambda`` in results.
    joint
        Name of the joint (group) it belongs to.
    expression
        ``pi`` as written, in point velocities, angular velocities, coordinates and time.
    e
        ``e_C``: ``pi`` with every velocity set to zero.
    shares
        One :class:`BodyShare` per body the constraint acts on.
    position
        Optional ``phi(q, t)`` whose time derivative is ``pi`` on the constraint manifold
        (a holonomic constraint): ``phi = 0`` is checked and enforced at position level.
    """

    name: str
    joint: str
    expression: ca.SX
    e: ca.SX
    shares: list[BodyShare]
    position: ca.SX | None = None

    @property
    def bodies(self) -> list[Body]:
        return [s.body for s in self.shares]


@dataclass(eq=False)
class Joint:
    """A named group of scalar constraints sharing one application point per body."""

    name: str
    constraints: list[Constraint] = field(default_factory=list)
    points: dict[str, Point] = field(default_factory=dict)

    @property
    def bodies(self) -> list[Body]:
        seen: dict[str, Body] = {}
        for c in self.constraints:
            for s in c.shares:
                seen.setdefault(s.body.name, s.body)
        return list(seen.values())

    def share_on(self, body: Body) -> tuple[Point, ca.SX, ca.SX]:
        """Point and the ``(n_constraints x 3)`` gradient rows ``f``, ``h`` for ``body``."""
        point = self.points[body.name]
        F, H = [], []
        for c in self.constraints:
            s = next((s for s in c.shares if s.body is body), None)
            F.append(ca.SX(1, 3) if s is None else s.f.T)
            H.append(ca.SX(1, 3) if s is None else s.h.T)
        return point, ca.vertcat(*F), ca.vertcat(*H)


def _velocity_symbols(bodies: list[Body]) -> list[tuple[str, ca.SX, Body, Point | None]]:
    out = []
    for b in bodies:
        out.append((f"{b.name}.omega", b.omega, b, None))
        for p in b.points.values():
            label = f"{b.name}.vbar" if p.name == "com" else f"{p.label}.v"
            out.append((label, p.v, b, p))
    return out


def derive_prescription(
    name: str,
    expression,
    bodies: list[Body],
    time: ca.SX,
    extra_symbols: ca.SX,
    application_points: dict[str, Point],
) -> tuple[ca.SX, list[BodyShare]]:
    """Differentiate ``pi`` into ``e`` and per-body ``(point, f, h)`` (paper eqs. 25-26, 32).

    ``application_points`` maps a body name to the joint's point on that body; a body
    without one takes the first point the constraint uses (and is added to the map).
    Raises :class:`NonAffineConstraintError` if ``pi`` is not affine in the velocities.
    """
    if not isinstance(expression, ca.SX):
        if isinstance(expression, ca.MX):
            raise ModelError(f"constraint '{name}': write the expression with SX symbols, not MX")
        raise ModelError(
            f"constraint '{name}': expression must be a CasADi SX expression in point velocities "
            f"(P.v) and angular velocities (body.omega), got {type(expression).__name__}"
        )
    if expression.shape != (1, 1):
        raise ModelError(f"constraint '{name}': expression must be scalar, got shape {expression.shape}")
    vel = _velocity_symbols(bodies)
    # Dependence by symbol identity: one symvar per expression and set look-ups, instead of
    # ca.depends_on over every point of every body (which dominated model building).
    vel_of = {s.element_hash(): label for label, v, _, _ in vel for s in ca.symvar(v)}
    allowed = set(vel_of)
    allowed.update(s.element_hash() for x in (time, extra_symbols, *[b.q for b in bodies]) for s in ca.symvar(x))
    used_symbols = ca.symvar(expression)
    for s in used_symbols:
        if s.element_hash() not in allowed:
            raise ModelError(
                f"constraint '{name}' uses the symbol '{s.name()}', which is not a coordinate, "
                "velocity, input or the time of this model (was the body added to the model?)"
            )
    used_labels = {vel_of[h] for h in (s.element_hash() for s in used_symbols) if h in vel_of}
    used = [(label, v, b, p) for label, v, b, p in vel if label in used_labels]
    if not used:
        raise ModelError(
            f"constraint '{name}' does not involve any velocity: write it at velocity level, "
            "pi = f . v_C + h . omega + e (a position constraint phi(q) = 0 becomes d(phi)/dt = 0)"
        )
    grads = {}
    for label, v, b, p in used:
        g = ca.gradient(expression, v)
        in_g = {vel_of.get(s.element_hash()) for s in ca.symvar(g)}
        label2 = next((lab for lab, _, _, _ in vel if lab in in_g), None)   # first in model order, as before
        if label2 is not None:
            raise NonAffineConstraintError(
                f"constraint '{name}' is not affine in the velocities: its derivative with "
                f"respect to {label} depends on {label2}. A constraint must read "
                "pi = f . v_C + h . omega + e with f, h, e functions of coordinates and time "
                "only (paper eq. 25)"
            )
        grads[label] = g
    all_vel = ca.vertcat(*[v for _, v, _, _ in used])
    e = ca.substitute(expression, all_vel, ca.SX.zeros(all_vel.shape))
    shares = []
    for b in bodies:
        mine = [(label, p) for label, _, bb, p in used if bb is b]
        if not mine:
            continue
        pts = [p for _, p in mine if p is not None]
        point = application_points.get(b.name) or (pts[0] if pts else b.com)
        application_points.setdefault(b.name, point)
        f = ca.SX(3, 1)  # structural zeros: a pure-force constraint builds no moment terms
        h = ca.SX(3, 1)
        for label, p in mine:
            if p is None:
                h = h + grads[label]
            else:
                # eq. (32): the same constraint written at the joint's point X_A.
                f = f + grads[label]
                if p is not point:
                    h = h + ca.cross(p.position - point.position, grads[label])
        shares.append(BodyShare(b, point, ca.sparsify(ca.simplify(f)), ca.sparsify(ca.simplify(h))))
    return e, shares


def equipollent_moment(force, moment, from_position, to_position):
    """Moment of the load moved from ``x_C`` to ``x_A``: ``M_A = M_C + (x_C - x_A) x F`` (eq. 33)."""
    return moment + ca.cross(from_position - to_position, force)
