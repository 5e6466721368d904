"""The equations of motion in joint coordinates (paper sec. 5, eqs. 34-44).

Every body that hangs on a library joint with a known parameterization
(:mod:`~ocp_constraints.mechanics.joint_maps`: revolute, prismatic, weld) gets its pose as an
explicit function of its base's pose and the joint's coordinates ``s``; a body on no such
joint keeps its own coordinates and speeds. With ``p`` the joint coordinates (and the free
bodies' coordinates) and ``u_r`` their speeds, the bodies' speeds are ``u = J(p) u_r`` and
their accelerations ``u' = J u_r' + J' u_r``. Projecting the Newton-Euler balances
``M u' = f + G^T lambda`` onto ``J`` removes the multipliers of the constraints the
parameterization satisfies identically (``G_joint J = 0``, the ``Phi_Gamma = lambda
A_Gamma`` of eqs. 38-41 with ``A = G B dq/dp``):

    M_r u_r' = f_r + G_r^T lambda_r,    M_r = J^T M J,  f_r = J^T (f - M J' u_r),  G_r = G_rest J,

and only the other constraints (loop closures, contacts, constraints written by hand) stay,
with their multipliers ``lambda_r``. :class:`JointCoordinates` presents these with the
attributes of :class:`~ocp_constraints.mechanics.equations.SystemEquations` (``q, u, qdot,
mass_matrix, forces, G, e, phi, ...``), and maps them back: :attr:`JointCoordinates.body_state`
(every body coordinate and speed) and :meth:`JointCoordinates.multipliers` (every multiplier:
a joint's from the balance of its body, body by body from the leaves, least squares on the
joint's rows ``G_j``, exact because the residual lies in the range of ``G_j^T``).

Euler-angle bodies: the angles are recovered from the rotation ``Q`` and unwrapped about
their linearization at ``p = 0``, so an angle that is linear in the joint coordinates (a
hinge about the sequence's first or last axis) is exactly that, with no branch cut. A
quaternion body's quaternion is the product of its base's, the joint's ``(cos s/2, sin s/2 n)``
and the fixed ``R0``'s: unit and continuous in the joint coordinates.
"""
from __future__ import annotations

from functools import cached_property

import casadi as ca
import numpy as np

from ..errors import ModelError
from .equations import SystemEquations, unit_lengths
from .joint_maps import KINDS, axis_rotation
from .rotations import EulerSequence, quaternion_from_rotation


class JointCoordinates:
    """The equations of ``eqs`` in joint coordinates, with the interface of ``SystemEquations``."""

    def __init__(self, eqs: SystemEquations):
        self.full = eqs
        self.model = eqs.model
        self.t, self.inputs, self.input_rates = eqs.t, eqs.inputs, eqs.input_rates
        self.maps = _choose_maps(eqs)
        self._build_poses()
        covered = {c for m in self.maps.values() for c in m.constraints}
        self.rest = [k for k, n in enumerate(eqs.constraint_names) if n not in covered]
        self.covered = [k for k, n in enumerate(eqs.constraint_names) if n in covered]
        self.constraint_names = [eqs.constraint_names[k] for k in self.rest]
        self.constraints = [eqs.constraints[k] for k in self.rest]
        self.nq, self.nu, self.nc = self.q.numel(), self.u.numel(), len(self.rest)

        sub = self.substitute
        self.J = ca.jacobian(self.u_full, self.u)
        # u' = J u_r' + (d(J u_r)/dp) p' (the maps are scleronomic: no explicit time).
        self.bias = ca.jtimes(self.u_full, self.q, self.qdot)
        M = sub(eqs.mass_matrix)
        self.M_full, self.f_full = M, sub(eqs.forces)
        self.mass_matrix = self.J.T @ M @ self.J
        self.forces = self.J.T @ (self.f_full - M @ self.bias)
        self.G_full = sub(eqs.G)
        rows = self.rest
        self.G = self.G_full[rows, :] @ self.J if rows else ca.SX(0, self.nu)
        self.e = sub(eqs.e[rows]) if rows else ca.SX(0, 1)
        self.holonomic = [i for i, k in enumerate(rows) if k in eqs.holonomic]
        kept = [eqs.holonomic.index(k) for k in rows if k in eqs.holonomic]
        self.phi = sub(eqs.phi[kept]) if kept else ca.SX(0, 1)
        # A body on a mapped joint has a composed unit quaternion; one on none keeps its own (and its length row).
        own = [b for b in eqs.bodies if b.name not in self.maps]
        self.unit_length_bodies = [b.name for b in own if b.name in eqs.unit_length_bodies]
        self.position_rows = ca.vertcat(self.phi, unit_lengths(own))
        pi = self.G @ self.u + self.e
        self.gamma = ca.jtimes(pi, self.q, self.qdot) + ca.jacobian(pi, self.t)
        if self.inputs.numel() and self.nc:
            self.gamma += ca.jtimes(pi, self.inputs, self.input_rates)
        self.bodies = eqs.bodies

    # -- poses -----------------------------------------------------------------------------
    def _build_poses(self) -> None:
        """Every body's ``xbar, Q, vbar, omega`` as expressions of the joint coordinates, parents first."""
        q, u, qdot, names, speed_names = [], [], [], [], []
        pose: dict[str, tuple] = {}
        self.joint_symbols: dict[str, tuple[ca.SX, ca.SX]] = {}
        for b in _parents_first(self.full.bodies, self.maps):
            m = self.maps.get(b.name)
            if m is None:
                q.append(b.q), u.append(b.u), qdot.append(b.coordinate_rates())
                names += b.coordinate_names
                speed_names += b.speed_names
                pose[b.name] = (b.xbar, b.Q, b.vbar, b.omega, _own_quaternion(b))
                continue
            n = len(KINDS[m.kind])
            s, sd = ca.SX.sym(f"{m.joint}.s", n), ca.SX.sym(f"{m.joint}.s_dot", n)
            self.joint_symbols[b.name] = (s, sd)
            q.append(s), u.append(sd), qdot.append(sd)
            names += m.coordinate_names
            speed_names += [f"{n}_dot" for n in m.coordinate_names]
            pose[b.name] = _child_pose(m, pose, s, sd)
        self.q, self.u, self.qdot = ca.vertcat(*q), ca.vertcat(*u), ca.vertcat(*qdot)
        self.coordinate_names = names
        self.speed_names = speed_names
        reference = self.reference_point()
        qb, ub = [], []
        for b in self.full.bodies:
            xbar, Q, vbar, omega, quaternion = pose[b.name]
            if b.name not in self.maps:
                qb.append(b.q)
            elif isinstance(b.rotation, EulerSequence):
                qb.append(ca.vertcat(xbar, _euler_angles(b, Q, self.q, reference)))
            else:       # the composed unit quaternion: continuous in the joint coordinates, no branch
                qb.append(ca.vertcat(xbar, quaternion))
            ub.append(ca.vertcat(vbar, omega))
        self.q_full, self.u_full = ca.vertcat(*qb), ca.vertcat(*ub)

    def reference_point(self) -> np.ndarray:
        """``p = 0`` for joint coordinates; free bodies at their origin (unit quaternion)."""
        ref = np.zeros(self.q.numel())
        k = 0
        for b in _parents_first(self.full.bodies, self.maps):
            if b.name in self.maps:
                k += len(KINDS[self.maps[b.name].kind])
            else:
                if not isinstance(b.rotation, EulerSequence):
                    ref[k + 3] = 1.0
                k += b.q.numel()
        return ref

    def substitute(self, expr):
        """A maximal-coordinate expression (of the bodies' ``q``, ``u``) in joint coordinates."""
        f = self.full
        return ca.substitute(expr, ca.vertcat(f.q, f.u), ca.vertcat(self.q_full, self.u_full))

    # -- back to maximal quantities ---------------------------------------------------------
    @cached_property
    def multiplier_symbols(self) -> tuple[ca.SX, ca.SX]:
        """``(a, lambda_r)``: symbols of the reduced accelerations and remaining multipliers."""
        return ca.SX.sym("a_r", self.nu), ca.SX.sym("lam_r", self.nc)

    def accelerations_full(self, a: ca.SX) -> ca.SX:
        """The bodies' ``u' = J a + J' u_r``."""
        return self.J @ a + self.bias

    @cached_property
    def multiplier_expression(self) -> ca.SX:
        """Every multiplier of the model (its constraint order) from ``p, u_r, a, lambda_r, inputs, t``.

        The remaining constraints' are ``lambda_r``; a joint's follow from its body's six
        balance rows minus what the body's children's joints carry (leaves first):
        ``lambda_j = (G_jb G_jb^T)^{-1} G_jb rho_b`` with ``rho_b`` the balance residual of body
        ``b`` (``M u' - f - G_rest^T lambda_r``, restricted to ``b``) (paper eqs. 38-41).
        """
        a, lam_r = self.multiplier_symbols
        full = self.full
        rho = self.M_full @ self.accelerations_full(a) - self.f_full
        if self.nc:
            rho -= self.G_full[self.rest, :].T @ lam_r
        lam = [None] * full.nc
        for k, r in zip(self.rest, range(self.nc)):
            lam[k] = lam_r[r]
        index = {n: k for k, n in enumerate(full.constraint_names)}
        offsets = np.cumsum([0] + [b.u.numel() for b in full.bodies])
        speeds = {b.name: list(range(offsets[i], offsets[i + 1])) for i, b in enumerate(full.bodies)}
        carried = {b.name: ca.SX.zeros(6, 1) for b in full.bodies}
        for b in reversed(_parents_first(full.bodies, self.maps)):
            m = self.maps.get(b.name)
            if m is None:
                continue
            rows = [index[c] for c in m.constraints]
            Gb = self.G_full[rows, speeds[b.name]]
            lam_j = ca.solve(Gb @ Gb.T, Gb @ (rho[speeds[b.name]] - carried[b.name]))
            for r, k in enumerate(rows):
                lam[k] = lam_j[r]
            if m.other is not None:
                base = m.other.body.name
                carried[base] += self.G_full[rows, speeds[base]].T @ lam_j
        return ca.vertcat(*lam) if lam else ca.SX(0, 1)

    @cached_property
    def maximal_function(self) -> ca.Function:
        """``(p, u_r, a, lambda_r, inputs, t) -> (q, u, u', lambda)`` of the maximal model."""
        a, lam_r = self.multiplier_symbols
        return ca.Function("maximal_state", [self.q, self.u, a, lam_r, self.inputs, self.t],
                           [self.q_full, self.u_full, self.accelerations_full(a), self.multiplier_expression],
                           ["p", "u_r", "a", "lam_r", "inputs", "t"], ["q", "u", "udot", "lam"])

    @cached_property
    def forward_accelerations(self) -> ca.SX:
        """``a = M_r^{-1} (f_r + G_r^T lambda_r)`` from ``p, u_r, lambda_r, inputs, t`` (symbolic solve;
        built only where a joint's multiplier enters an objective or a path constraint)."""
        _, lam_r = self.multiplier_symbols
        return ca.solve(self.mass_matrix, self.forces + self.G.T @ lam_r)

    @cached_property
    def pose_functions(self) -> ca.Function:
        """``p -> (q, d q / d p)`` and ``p -> J``, for fitting joint coordinates to a maximal guess."""
        return ca.Function("pose", [self.q], [self.q_full, ca.jacobian(self.q_full, self.q), self.J],
                           ["p"], ["q", "dq_dp", "J"])


def joint_coordinates_pay(eqs: SystemEquations) -> bool:
    """Whether ``coordinates="auto"`` takes joint coordinates: some body hangs on a library joint
    with a known parameterization and every such joint is used (no closed chain of library
    joints, where the joint form converged more slowly: the four-bar took 75 IPOPT iterations
    against 35). Contacts and constraints written by hand may remain; they keep their rows."""
    recorded = [m for m in getattr(eqs.model, "joint_maps", {}).values() if m is not None]
    if not recorded:
        return False
    chosen = _choose_maps(eqs)
    covered = {c for m in chosen.values() for c in m.constraints}
    return bool(chosen) and all(set(m.constraints) <= covered for m in recorded)


def _choose_maps(eqs: SystemEquations) -> dict:
    """Body name -> the joint map that places it: its first recorded joint whose base is placed and
    whose points are fixed in their bodies. Bodies left over (and the other joints of a closed
    loop) keep their coordinates and constraints."""
    maps = [m for m in getattr(eqs.model, "joint_maps", {}).values() if m is not None]
    present = set(eqs.constraint_names)

    def usable(m) -> bool:
        b = m.point.body
        return (not ca.depends_on(m.point.offset, b.q)
                and (m.other is None or not ca.depends_on(m.other.offset, m.other.body.q))
                and all(c in present for c in m.constraints))

    chosen: dict = {}
    free = {b.name for b in eqs.bodies if not any(usable(m) and m.point.body is b for m in maps)}
    while len(chosen) + len(free) < len(eqs.bodies):
        progress = False
        for m in maps:
            b = m.point.body.name
            if b in chosen or b in free or not usable(m):
                continue
            if m.other is None or m.other.body.name in chosen or m.other.body.name in free:
                chosen[b] = m
                progress = True
        if not progress:       # a closed chain of joints: its first body keeps its coordinates
            free.add(next(b.name for b in eqs.bodies if b.name not in chosen and b.name not in free))
    return chosen


def _parents_first(bodies, maps: dict) -> list:
    """The bodies ordered so that every placed body comes after its base."""
    out, done = [], set()
    pending = list(bodies)
    while pending:
        for b in list(pending):
            m = maps.get(b.name)
            if m is None or m.other is None or m.other.body.name in done:
                out.append(b)
                done.add(b.name)
                pending.remove(b)
    return out


def _child_pose(m, pose: dict, s: ca.SX, sd: ca.SX) -> tuple:
    """``xbar, Q, vbar, omega`` of a joint's body from its base's pose and ``s, s'`` (the map's kind)."""
    if m.other is None:
        Q2, x2, w2, v2 = ca.SX.eye(3), ca.SX(ca.DM(m.anchor)), ca.SX.zeros(3, 1), ca.SX.zeros(3, 1)
        q2 = ca.SX(ca.DM([1.0, 0.0, 0.0, 0.0]))
    else:
        xb, Q2, vb, w2, q2 = pose[m.other.body.name]
        x2 = xb + Q2 @ ca.evalf(m.other.offset)
        v2 = vb + ca.cross(w2, x2 - xb)
    d = Q2 @ ca.DM(m.axis)
    R0 = ca.DM(m.R0)
    if m.kind == "revolute":
        Q1, w1, xc, vc = Q2 @ axis_rotation(m.axis, s[0]) @ R0, w2 + d * sd[0], x2, v2
    elif m.kind == "prismatic":
        Q1, w1 = Q2 @ R0, w2
        xc = x2 + d * s[0]
        vc = v2 + ca.cross(w2, xc - x2) + d * sd[0]
    else:
        Q1, w1, xc, vc = Q2 @ R0, w2, x2, v2
    # The body's unit quaternion q_2 (x) q(n, s) (x) q(R0) (Hamilton products: Q(a (x) b) = Q(a) Q(b)).
    turn = _axis_quaternion(m.axis, s[0]) if m.kind == "revolute" else ca.SX(ca.DM([1.0, 0.0, 0.0, 0.0]))
    quaternion = _quaternion_product(_quaternion_product(q2, turn), ca.SX(ca.DM(quaternion_from_rotation(m.R0))))
    xbar = xc - Q1 @ ca.evalf(m.point.offset)
    vbar = vc + ca.cross(w1, xbar - xc)
    return xbar, Q1, vbar, w1, quaternion


def _quaternion_product(a, b) -> ca.SX:
    """Hamilton product ``a (x) b`` of ``(w, x, y, z)`` quaternions."""
    return ca.vertcat(a[0] * b[0] - ca.dot(a[1:4], b[1:4]), a[0] * b[1:4] + b[0] * a[1:4] + ca.cross(a[1:4], b[1:4]))


def _axis_quaternion(n, s) -> ca.SX:
    """The unit quaternion of ``R(n, s)``: ``(cos s/2, sin s/2 n)``."""
    return ca.vertcat(ca.cos(s / 2), ca.sin(s / 2) * ca.DM(np.asarray(n, float).reshape(3, 1)))


def _own_quaternion(body) -> ca.SX:
    """A body's unit quaternion from its own coordinates (Euler angles or a quaternion, normalized)."""
    r = body.rotation_parameters
    if not isinstance(body.rotation, EulerSequence):
        return r / ca.norm_2(r)
    out = ca.SX(ca.DM([1.0, 0.0, 0.0, 0.0]))
    for k in range(3):
        axis = np.eye(3)[int(body.rotation.axes[k]) - 1]
        out = _quaternion_product(out, _axis_quaternion(axis, r[k]))
    return out


def euler_from_rotation(axes: str, Q) -> list:
    """Raw angles ``(a1, a2, a3)`` with ``Q = R_i(a1) R_j(a2) R_k(a3)`` (``a1, a3`` in ``(-pi, pi]``).

    Tait-Bryan ``ijk`` (``e`` the sign of the permutation): ``a2 = asin(e Q_ik)``,
    ``a1 = atan2(-e Q_jk, Q_kk)``, ``a3 = atan2(-e Q_ij, Q_ii)``; proper ``iji`` (``k`` the third
    axis): ``a2 = acos(Q_ii)``, ``a1 = atan2(Q_ji, -e Q_ki)``, ``a3 = atan2(Q_ij, e Q_ik)``. The
    middle angle is taken by ``atan2`` (smooth where the sequence is regular).
    """
    i, j = int(axes[0]) - 1, int(axes[1]) - 1
    if axes[0] != axes[2]:
        k = int(axes[2]) - 1
        e = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
        a2 = ca.atan2(e * Q[i, k], ca.sqrt(Q[i, i] ** 2 + Q[i, j] ** 2))
        return [ca.atan2(-e * Q[j, k], Q[k, k]), a2, ca.atan2(-e * Q[i, j], Q[i, i])]
    k = 3 - i - j
    e = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    a2 = ca.atan2(ca.sqrt(Q[i, j] ** 2 + Q[i, k] ** 2), Q[i, i])
    return [ca.atan2(Q[j, i], -e * Q[k, i]), a2, ca.atan2(Q[i, j], e * Q[i, k])]


def _euler_angles(body, Q, p: ca.SX, reference: np.ndarray) -> ca.SX:
    """The body's Euler angles from ``Q(p)``, the first and third unwrapped about their linearization
    at ``p = reference`` (so an angle linear in ``p`` is exactly linear, with no branch cut)."""
    raw = euler_from_rotation(body.rotation.axes, Q)
    out = [raw[1]]
    for r in (0, 2):
        f = ca.Function("angle", [p], [raw[r], ca.jacobian(raw[r], p)])
        value, slope = (np.asarray(v, float).ravel() for v in f(reference))
        if not (np.isfinite(value).all() and np.isfinite(slope).all()):
            raise ModelError(f"body '{body.name}': its {body.rotation.axes} Euler angles are singular at the joint "
                             f"coordinates' zero; give it rotation='321' or another sequence regular there, or "
                             f"solve with coordinates='maximal'")
        linear = float(value[0]) + ca.dot(ca.DM(slope), p - ca.DM(reference))
        out.insert(r, linear + ca.atan2(ca.sin(raw[r] - linear), ca.cos(raw[r] - linear)))
    return ca.vertcat(*out)
