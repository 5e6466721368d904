"""The robot a URDF becomes (:func:`~ocp_constraints.mechanics.urdf.load_urdf`): its model, joints, limits
and joint-space kinematics, and helpers to pose optimal-control problems on it.

Joint space -> the model's maximal coordinates: every body's link frame is the product of the
joint origins and joint motions from the root (``R_o Rot(a, q)`` for a revolute joint,
``p_o + R_o a q`` for a prismatic one); speeds ``vbar = d(xbar)/dt`` and ``omega = axial(Q' Q^T)``
(paper sec. 2) and their rates are CasADi derivatives of those products.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..errors import ModelError
from . import joints_spatial as js
from .model import Model
from .rotations import quaternion_from_rotation

MOVABLE = ("revolute", "continuous", "prismatic")


@dataclass(frozen=True)
class JointLimit:
    """A URDF ``<limit>``: position (rad or m), speed (rad/s or m/s) and effort (N m or N); inf if absent."""

    lower: float = -np.inf
    upper: float = np.inf
    velocity: float = np.inf
    effort: float = np.inf


@dataclass(eq=False)
class RobotJoint:
    """A joint of the model: its URDF data in the model's bodies (``parent`` None: the ground)."""

    name: str
    urdf_name: str
    type: str
    parent: str | None
    child: str
    origin: np.ndarray            # 4x4: the joint frame at q = 0 in the parent body's link frame (world for ground)
    axis: np.ndarray              # unit axis in the joint (child link) frame
    limit: JointLimit
    index: int | None = None      # position in the joint-space vector (movable joints)
    input: str | None = None


@dataclass(eq=False)
class Robot:
    """A model built from a URDF, with its joint-space kinematics.

    ``model`` is an ordinary :class:`~ocp_constraints.mechanics.model.Model`: simulate it,
    solve its inverse dynamics, pose optimal-control problems on it, export it to C.
    ``joint_names`` are the movable joints in the order of the joint-space vectors taken by
    :meth:`body_states` (the tree breadth first from the root,
    each link's joints in file order). ``frames`` maps every link to ``(body or None, T)``,
    its pose in that body's link frame (or in the world for the ground).
    """

    model: Model
    joints: dict[str, RobotJoint]
    joint_names: list[str]
    frames: dict[str, tuple[str | None, np.ndarray]]
    urdf_names: dict[str, str]
    com: dict[str, np.ndarray]
    notes: list[str] = field(default_factory=list)

    # -- limits -----------------------------------------------------------------------------
    @property
    def limits(self) -> dict[str, JointLimit]:
        """Joint name -> :class:`JointLimit` of every movable joint."""
        return {n: self.joints[n].limit for n in self.joint_names}

    @property
    def input_bounds(self) -> dict[str, tuple[float, float]]:
        """Effort limits as ``{input: (lower, upper)}``: ``for n, b in robot.input_bounds.items(): problem.bound(n, *b)``."""
        return {j.input: (-j.limit.effort, j.limit.effort) for n in self.joint_names
                if (j := self.joints[n]).input and np.isfinite(j.limit.effort)}

    def limit_constraints(self) -> list[tuple[str, ca.SX, float, float]]:
        """Position and speed limits as ``(label, expression, lower, upper)`` for ``problem.subject_to``.

        A revolute range ``[lo, hi]`` becomes ``cos(theta - c) >= cos(w)`` (``c``, ``w``: its
        middle and half-width): smooth, and exact for any range shorter than a turn; a range of a
        turn or more does not restrict the orientation and is left out (see :attr:`notes`).
        """
        out = []
        for n in self.joint_names:
            j, lim = self.joints[n], self.joints[n].limit
            if np.isfinite(lim.lower) and np.isfinite(lim.upper):
                if j.type == "prismatic":
                    out.append((f"{n} position", self.joint_position(n), lim.lower, lim.upper))
                elif lim.upper - lim.lower < 2 * np.pi:
                    c, w = 0.5 * (lim.upper + lim.lower), 0.5 * (lim.upper - lim.lower)
                    cos, sin = self._cos_sin(n)
                    out.append((f"{n} position", cos * np.cos(c) + sin * np.sin(c), float(np.cos(w)), np.inf))
            if np.isfinite(lim.velocity):
                out.append((f"{n} speed", self.joint_rate(n), -lim.velocity, lim.velocity))
        return out

    def apply_limits(self, problem, positions: bool = True, speeds: bool = True, efforts: bool = True) -> None:
        """Put the URDF limits on ``problem`` (an OptimalControlProblem on :attr:`model`)."""
        if efforts:
            for name, (lo, hi) in self.input_bounds.items():
                problem.bound(name, lo, hi)
        for label, expr, lo, hi in self.limit_constraints():
            if (positions and label.endswith("position")) or (speeds and label.endswith("speed")):
                problem.subject_to(expr, lo, hi, label)

    # -- joint coordinates as expressions of the model's coordinates ---------------------------
    def _joint(self, name: str) -> RobotJoint:
        if name not in self.joint_names:
            raise ModelError(f"robot '{self.model.name}' has no movable joint '{name}' (movable joints: "
                             f"{', '.join(self.joint_names)})")
        return self.joints[name]

    def _relative(self, j: RobotJoint) -> ca.SX:
        """The child basis in the joint frame: ``R_o^T Q_p^T Q_c`` (a rotation about the axis)."""
        Qp = ca.DM.eye(3) if j.parent is None else self.model.bodies[j.parent].Q
        return ca.DM(j.origin[:3, :3]).T @ Qp.T @ self.model.bodies[j.child].Q

    def _cos_sin(self, name: str) -> tuple[ca.SX, ca.SX]:
        j = self._joint(name)
        b1, b2 = (np.asarray(v).ravel() for v in js._complement(ca.DM(j.axis)))
        R = self._relative(j)
        Rb1 = R @ ca.DM(b1)
        return ca.dot(ca.DM(b1), Rb1), ca.dot(ca.DM(b2), Rb1)

    def joint_position(self, name: str) -> ca.SX:
        """The joint's coordinate from the bodies' coordinates: angle (rad, ``atan2``, in ``(-pi, pi]``) or
        displacement along the axis (m)."""
        j = self._joint(name)
        if j.type == "prismatic":
            Qp = ca.DM.eye(3) if j.parent is None else self.model.bodies[j.parent].Q
            xp = ca.DM(j.origin[:3, 3]) if j.parent is None else self._link_origin(j.parent) + Qp @ ca.DM(j.origin[:3, 3])
            return ca.dot(Qp @ ca.DM(j.origin[:3, :3]) @ ca.DM(j.axis), self._link_origin(j.child) - xp)
        cos, sin = self._cos_sin(name)
        return ca.atan2(sin, cos)

    def joint_rate(self, name: str) -> ca.SX:
        """The joint's rate (rad/s or m/s) as an expression of the model's coordinates and speeds."""
        j = self._joint(name)
        child = self.model.bodies[j.child]
        a = child.Q @ ca.DM(j.axis)
        if j.type == "prismatic":
            parent = None if j.parent is None else self.model.bodies[j.parent]
            vp = 0 if parent is None else parent.vbar + ca.cross(parent.omega, self._link_origin(j.child) - parent.xbar)
            return ca.dot(a, child.vbar + ca.cross(child.omega, self._link_origin(j.child) - child.xbar) - vp)
        wp = 0 if j.parent is None else self.model.bodies[j.parent].omega
        return ca.dot(a, child.omega - wp)

    def _link_origin(self, body: str) -> ca.SX:
        b = self.model.bodies[body]
        return b.xbar - b.Q @ ca.DM(self.com[body])

    # -- joint space -> the model's coordinates and speeds --------------------------------------
    def _kinematics(self) -> ca.Function:
        f = self.__dict__.get("_fk")
        if f is not None:
            return f
        n = len(self.joint_names)
        q, qd, qdd = (ca.SX.sym(s, n) for s in ("q", "qd", "qdd"))
        pose: dict[str | None, tuple] = {None: (ca.SX.eye(3), ca.SX.zeros(3, 1))}
        for j in self.joints.values():                      # parents come first (built in tree order)
            Rp, pp = pose[j.parent]
            R = Rp @ ca.DM(j.origin[:3, :3])
            p = pp + Rp @ ca.DM(j.origin[:3, 3])
            if j.type in ("revolute", "continuous"):
                R = R @ _axis_rotation(j.axis, q[j.index])
            elif j.type == "prismatic":
                p = p + R @ ca.DM(j.axis) * q[j.index]
            pose[j.child] = (R, p)
        xs, Rs, ws = [], [], []
        for name in self.model.bodies:
            R, p = pose[name]
            x = p + R @ ca.DM(self.com[name])
            Rdot = ca.reshape(ca.jtimes(ca.vec(R), q, qd), 3, 3)
            W = Rdot @ R.T
            xs.append(x)
            Rs.append(ca.vec(R))
            ws.append(ca.vertcat(x, ca.vertcat(W[2, 1], W[0, 2], W[1, 0])))
        x = ca.vertcat(*xs)
        u = ca.vertcat(*[ca.vertcat(ca.jtimes(w[:3], q, qd), w[3:]) for w in ws])
        udot = ca.jtimes(u, q, qd) + ca.jtimes(u, qd, qdd)
        f = ca.Function("robot_kinematics", [q, qd, qdd], [x, ca.vertcat(*Rs), u, udot])
        self.__dict__["_fk"] = f
        return f

    def body_states(self, q, qd=None, qdd=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The model's coordinates, speeds and their rates (rows are samples) from joint positions,
        rates and accelerations (rows are samples, columns :attr:`joint_names`; rad or m).

        Quaternions keep one sign along the samples, with ``qw >= 0`` at the first. Feed them to
        ``InverseDynamics(SystemEquations(robot.model)).solve(t, *robot.body_states(q, qd, qdd))``.
        """
        n = len(self.joint_names)
        q = np.atleast_2d(np.asarray(q, float))
        qd = np.zeros_like(q) if qd is None else np.atleast_2d(np.asarray(qd, float))
        qdd = np.zeros_like(q) if qdd is None else np.atleast_2d(np.asarray(qdd, float))
        for what, a in (("q", q), ("qd", qd), ("qdd", qdd)):
            if a.shape[1:] != (n,) or a.shape[0] != q.shape[0] or not np.all(np.isfinite(a)):
                raise ModelError(f"robot '{self.model.name}': joint {what} must be finite, samples x {n} "
                                 f"({', '.join(self.joint_names)}), got shape {a.shape}")
        x, R, u, udot = (np.asarray(v).T for v in self._kinematics().map(len(q))(q.T, qd.T, qdd.T))
        rows = []
        for k, body in enumerate(self.model.bodies.values()):
            quats = quaternion_from_rotation(R[:, 9 * k: 9 * k + 9].reshape(-1, 3, 3).transpose(0, 2, 1))
            # One sign along the samples: sample i flips when its neighbour's (original) sign disagrees an odd
            # number of times up to it.
            turns = np.einsum("ij,ij->i", quats[1:], quats[:-1]) < 0
            quats[1:] *= np.where(np.cumsum(turns) % 2 == 1, -1.0, 1.0)[:, None]
            rows.append(np.hstack([x[:, 3 * k: 3 * k + 3], quats]))
        return np.hstack(rows), u, udot

    def coordinates(self, q) -> dict[str, float]:
        """``{coordinate name: value}`` of the model at one joint-space configuration."""
        return dict(zip(self.model.coordinate_names, self.body_states(np.atleast_2d(q))[0][0]))

    # -- optimal control: ends and guesses --------------------------------------------------------
    def set_boundary(self, problem, which: str, q, qd=None) -> list[str]:
        """Fix the configuration (and rates, default rest) at ``"initial"`` or ``"final"`` time.

        Only as many of the model's coordinates and speeds as the joints leave free are fixed
        (chosen by QR with column pivoting against the constraints' Jacobians), plus, at either end, one
        quaternion parameter per body that also fixes that quaternion's length. Returns the names fixed.

        That one is not redundant in effect: one parameter of a quaternion leaves the sign of the other free, a
        mirrored pose (cos(theta/2) fixed: theta or -theta). The final end fixed one alone until session 31, and a
        seventh newcomer's two-link arm asked to end at (45, 60) deg ended with its elbow at -150 deg from some
        starts (J = 7.16, below the true optimum's 9.074). Both fixed, the rows are consistent and IPOPT solves
        them (that arm: 25 iterations in joint coordinates, 44 in maximal ones).
        """
        from .equations import SystemEquations

        if which not in ("initial", "final"):
            raise ModelError(f"set_boundary: which must be 'initial' or 'final', got {which!r}")
        qm, um, _ = self.body_states(np.atleast_2d(q), None if qd is None else np.atleast_2d(qd))
        eqs = SystemEquations(self.model)
        J = np.asarray(ca.Function("J", [eqs.q], [ca.jacobian(eqs.phi, eqs.q)])(qm[0]))
        G = np.asarray(ca.Function("G", [eqs.q, eqs.t], [ca.densify(eqs.G)])(qm[0], 0.0))
        names = _complement_names(J, self.model.coordinate_names) + _complement_names(G, self.model.speed_names)
        values = dict(zip(self.model.coordinate_names + self.model.speed_names, np.concatenate([qm[0], um[0]])))
        (problem.initial if which == "initial" else problem.final)({n: float(values[n]) for n in names})
        return names

    def set_guess(self, problem, q_of_t) -> None:
        """Guess every coordinate and speed of ``problem`` from a joint-space path ``q_of_t(t) -> (len(t), n)``
        (speeds by central differences of it)."""
        last: dict = {}

        def states(t: np.ndarray):
            # Every column's guess asks for the same times in turn: the body states are computed once for them.
            if last.get("t") is None or not np.array_equal(last["t"], t):
                q = np.atleast_2d(q_of_t(t))
                h = 1e-6
                qd = (np.atleast_2d(q_of_t(t + h)) - np.atleast_2d(q_of_t(t - h))) / (2 * h)
                last.update(t=t.copy(), states=self.body_states(q, qd))
            return last["states"]

        def column(k: int, speeds: bool):
            def f(t):
                qm, um, _ = states(np.atleast_1d(np.asarray(t, float)))
                return (um if speeds else qm)[:, k].copy()
            return f

        for k, n in enumerate(self.model.coordinate_names):
            problem.set_guess(n, column(k, False))
        for k, n in enumerate(self.model.speed_names):
            problem.set_guess(n, column(k, True))


def _axis_rotation(axis: np.ndarray, angle) -> ca.SX:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    K = ca.DM([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return ca.DM.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * (K @ K)


def _complement_names(rows: np.ndarray, names: list[str]) -> list[str]:
    """Names whose values complete ``rows`` to full rank (QR with column pivoting on its null space)."""
    import scipy.linalg

    _, s, vt = np.linalg.svd(rows) if rows.size else (None, np.zeros(0), np.eye(len(names)))
    rank = int((s > 1e-9 * max(1.0, s[0] if s.size else 1.0)).sum())
    Z = vt[rank:].T
    if not Z.size:
        return []
    _, _, piv = scipy.linalg.qr(Z.T, pivoting=True)
    return [names[i] for i in sorted(piv[: Z.shape[1]])]
