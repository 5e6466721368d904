"""A model: bodies, constraints grouped into joints, applied loads and actuator inputs.

The model only describes; :mod:`ocp_constraints.mechanics.equations` turns it into equations and
the tasks (simulate, inverse dynamics) use those. Everything is addressed by name.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .bodies import Body, Point
from .constraints import Constraint, Joint, derive_prescription
from ..errors import ModelError
from .validate import check_finite, member_body


@dataclass(eq=False)
class PointForce:
    """Applied force (N, fixed basis) at a point; may depend on q, u, t and inputs."""

    name: str
    point: Point
    force: ca.SX


@dataclass(eq=False)
class BodyTorque:
    """Applied torque (N m, fixed basis) on ``body``; ``reaction_body`` gets the opposite."""

    name: str
    body: Body
    torque: ca.SX
    reaction_body: Body | None = None


@dataclass
class Model:
    """Bodies + constraints + applied loads.

    Parameters
    ----------
    name
        Scene name, written into results.
    gravity
        Gravitational acceleration vector (m/s^2, fixed basis); applied at every center
        of mass and counted in the potential energy.
    parameters
        The named parameter values the model was built with (SI), for the record.
    """

    name: str
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    parameters: dict[str, float] = field(default_factory=dict)
    bodies: dict[str, Body] = field(default_factory=dict)
    joints: dict[str, Joint] = field(default_factory=dict)
    forces: list[PointForce] = field(default_factory=list)
    torques: list[BodyTorque] = field(default_factory=list)
    inputs: dict[str, ca.SX] = field(default_factory=dict)
    #: constraint name -> what its multiplier is (written by the joint library; see :meth:`describe`)
    constraint_notes: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = ca.SX.sym("t")
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ModelError(f"model '{self.name}': gravity must be 3 finite numbers, got {self.gravity!r}")
        self.gravity = tuple(g)

    # -- building ----------------------------------------------------------------
    def add_body(self, name: str, mass: float, inertia, rotation="313", *, check_inertia: bool = True) -> Body:
        """Add a rigid body (see :class:`~ocp_constraints.mechanics.bodies.Body`, also for ``check_inertia``)."""
        if name in self.bodies:
            raise ModelError(f"model '{self.name}' already has a body named '{name}'")
        body = Body(name, mass, inertia, rotation, check_inertia=check_inertia)
        self.bodies[name] = body
        return body

    def add_input(self, name: str) -> ca.SX:
        """Declare a scalar actuator input (a control); use it in applied loads."""
        if name in self.inputs:
            raise ModelError(f"model '{self.name}' already has an input named '{name}'")
        s = ca.SX.sym(name)
        self.inputs[name] = s
        return s

    @property
    def input_vector(self) -> ca.SX:
        return ca.vertcat(*self.inputs.values()) if self.inputs else ca.SX(0, 1)

    def add_constraint(self, name: str, expression, joint: str | None = None, position=None, point: Point | None = None) -> Constraint:
        """Add the scalar constraint ``expression = 0`` (paper eq. 25).

        Parameters
        ----------
        name
            Unique constraint name (results column ``<name>.lambda``).
        expression
            SX expression affine in point velocities ``P.v`` and ``body.omega``.
        joint
            Joint (group) name; defaults to ``name``. Constraints of one joint share one
            application point per body.
        position
            Optional ``phi(q, t)`` with ``d(phi)/dt = pi`` on the constraint manifold, for
            a holonomic constraint; its residual is checked and kept at zero.
        point
            Application point to use for the joint on ``point.body`` (default: the first
            point a constraint of the joint uses on that body).
        """
        if any(name == c.name for j in self.joints.values() for c in j.constraints):
            raise ModelError(f"model '{self.name}' already has a constraint named '{name}'")
        joint_name = joint or name
        j = self.joints.get(joint_name) or Joint(joint_name)
        # Work on a copy of the joint's points: a rejected constraint changes nothing.
        points = dict(j.points)
        if point is not None:
            if not isinstance(point, Point):
                raise ModelError(f"constraint '{name}': point= must be a Point (body.point(...)), got "
                                 f"{type(point).__name__}")
            member_body(self, point.body, f"constraint '{name}': point= {point.label}")
            existing = points.get(point.body.name)
            if existing is not None and existing is not point:
                raise ModelError(
                    f"joint '{joint_name}' already acts at {existing.label} on body "
                    f"'{point.body.name}'; a joint has one application point per body"
                )
            points[point.body.name] = point
        e, shares = derive_prescription(
            name, expression, list(self.bodies.values()), self.t, self.input_vector, points
        )
        check_finite(expression, f"constraint '{name}'")
        if point is not None and point.body not in [sh.body for sh in shares]:
            raise ModelError(
                f"constraint '{name}': point= {point.label} is on body '{point.body.name}', which the constraint "
                f"does not involve (it acts on {', '.join(repr(sh.body.name) for sh in shares)}). Give a point of "
                "a body whose velocity the constraint uses, or leave point= out")
        if position is not None:
            if callable(position) and not isinstance(position, (ca.SX, ca.MX, ca.DM)):
                raise ModelError(f"constraint '{name}': position form is a Python function; give a CasADi SX "
                                 "expression phi(q, t) (of coordinates and model.t), or leave it out")
            position = ca.SX(position)
            if position.shape != (1, 1):
                raise ModelError(f"constraint '{name}': position form must be scalar")
            check_finite(position, f"constraint '{name}': position form")
        c = Constraint(name, joint_name, expression, e, shares, position)
        j.points = points
        j.constraints.append(c)
        self.joints[joint_name] = j
        return c

    def add_force(self, name: str, point: Point, force) -> PointForce:
        """Apply a force (N, fixed basis) at ``point``."""
        if not isinstance(point, Point):
            raise ModelError(f"force '{name}': point must be a Point (body.point(...)), got {type(point).__name__}")
        member_body(self, point.body, f"force '{name}' at {point.label}")
        f = PointForce(name, point, _vector3(force, f"force '{name}'"))
        self.forces.append(f)
        return f

    def add_torque(self, name: str, body: Body, torque, reaction_body: Body | None = None) -> BodyTorque:
        """Apply a torque (N m, fixed basis) to ``body`` (and minus it to ``reaction_body``)."""
        member_body(self, body, f"torque '{name}'")
        if reaction_body is not None:
            member_body(self, reaction_body, f"torque '{name}': reaction_body")
        tq = BodyTorque(name, body, _vector3(torque, f"torque '{name}'"), reaction_body)
        self.torques.append(tq)
        return tq

    # -- queries -----------------------------------------------------------------
    @property
    def constraints(self) -> list[Constraint]:
        return [c for j in self.joints.values() for c in j.constraints]

    @property
    def coordinate_names(self) -> list[str]:
        return [n for b in self.bodies.values() for n in b.coordinate_names]

    @property
    def speed_names(self) -> list[str]:
        return [n for b in self.bodies.values() for n in b.speed_names]

    def body(self, name: str) -> Body:
        try:
            return self.bodies[name]
        except KeyError:
            raise ModelError(f"model '{self.name}' has no body '{name}' (bodies: {', '.join(self.bodies)})") from None

    def joint(self, name: str) -> Joint:
        try:
            return self.joints[name]
        except KeyError:
            raise ModelError(f"model '{self.name}' has no joint '{name}' (joints: {', '.join(self.joints)})") from None

    def describe(self) -> str:
        """Every joint, its constraints, their multipliers and what each multiplier is (text).

        One block per joint: the bodies, the point its load acts at on each, and the
        ``loads.csv`` columns; then one line per scalar constraint: ``<name>.lambda`` and the
        force component (along which vector, in which basis) or moment component (about
        which axis) it is. Joints from :mod:`~ocp_constraints.mechanics.joints` say so in
        words; a constraint written by hand is described by its gradients
        ``f = d(pi)/d(v_C)`` and ``h = d(pi)/d(omega)`` (Lagrange's prescription, eq. 26).
        ``print(model.describe())`` to read it.
        """
        lines = [f"model '{self.name}': {len(self.bodies)} bodies, {len(self.joints)} joints, "
                 f"{len(self.constraints)} scalar constraints (one multiplier each)"]
        for j in self.joints.values():
            bodies = j.bodies
            where = ", ".join(f"'{b.name}' at {j.points[b.name].label}" for b in bodies)
            kind = "on one body" if len(bodies) == 1 else "between two bodies, equal and opposite loads"
            cols = [j.name] if len(bodies) == 1 else [f"{j.name}@{b.name}" for b in bodies]
            lines.append(f"joint '{j.name}' ({kind}): acts on {where}; loads.csv columns "
                         + " and ".join(f"{c}.*" for c in cols) + " (F_x/y/z, M_x/y/z, point_x/y/z, power)")
            for c in j.constraints:
                lines.append(f"  {c.name}.lambda: {self.constraint_notes.get(c.name) or _gradient_note(c)}")
        return "\n".join(lines)


def _gradient_note(c: Constraint) -> str:
    """What a hand-written constraint's multiplier is, from its gradients (eq. 26)."""
    parts = []
    for s in c.shares:
        for kind, v in (("force", s.f), ("moment", s.h)):
            if v.nnz():
                along = str(np.asarray(ca.evalf(v)).ravel().round(6).tolist()) if v.is_constant() \
                    else "a direction that depends on the coordinates"
                at = f" at {s.point.label}" if kind == "force" else ""
                parts.append(f"{kind} lambda x {along} (fixed basis) on '{s.body.name}'{at}")
    return "; ".join(parts)


def _vector3(value, what: str) -> ca.SX:
    if callable(value) and not isinstance(value, (ca.SX, ca.MX, ca.DM)):
        raise ModelError(f"{what} is a Python function; give 3 numbers or a 3x1 CasADi SX expression (of "
                         "model.t, coordinates, speeds, inputs) instead")
    try:
        v = ca.SX(value) if not isinstance(value, ca.SX) else value
    except (NotImplementedError, TypeError, ValueError, RuntimeError):
        raise ModelError(f"{what} must be 3 numbers or a 3x1 CasADi SX expression, got {value!r}") from None
    if v.shape == (1, 3):
        v = v.T
    if v.shape != (3, 1):
        raise ModelError(f"{what} must be a 3-vector, got shape {v.shape}")
    check_finite(v, what)
    return v
