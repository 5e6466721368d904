"""System assembly: Newton-Euler balances of all bodies with the prescribed constraint loads.

With speeds ``u = (vbar, omega)`` per body (fixed basis) the balances ``F = m vbar'``,
``M = H'`` (paper eq. 13) read, for all bodies at once,

    M(q) u' = f(q, u, t, inputs) + G(q, t)^T lambda,            (implicit, no inversion)
    G(q, t) u + e(q, t) = 0,                                     (the constraints, eq. 25)

where ``M = diag(m I, Q J Q^T)``, ``f`` holds the applied loads and the gyroscopic
terms ``-omega x (J omega)``, and row ``k`` of ``G`` is ``d(pi_k)/du``: Lagrange's
prescription ``F_c = lambda f_C`` at ``X_C``, ``M_c = lambda h_C`` (eq. 26) carried to the
center of mass. Everything is CasADi SX, so structural zeros are never evaluated.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from .bodies import Point
from .constraints import equipollent_moment
from ..errors import ModelError, RedundantConstraintsError
from .model import Model
from .rotations import UnitQuaternion
from .scaling import equilibrated


def unit_lengths(bodies) -> ca.SX:
    """``q . q - 1`` of the rotation parameters of every unit-quaternion body among ``bodies``.

    No constraint of the model: ``Q(q)`` divides by ``q . q`` (:class:`~.rotations.UnitQuaternion`), so the
    equations hold at any length and the kinematics ``q' = 1/2 Q(q) omega`` keep the length in exact time.
    A discretization keeps it only to its error, and an NLP whose boundary values leave it open scales it
    freely (a spherical pendulum's optimum 1.4952 returned as 0.0002 with ``|q| = 85``): a transcription
    holds it as a position-level row with its own slack, as it holds ``phi``."""
    rows = [ca.sumsqr(b.q[3:]) - 1.0 for b in bodies if isinstance(b.rotation, UnitQuaternion)]
    return ca.vertcat(*rows) if rows else ca.SX(0, 1)


@dataclass(frozen=True)
class LoadChannel:
    """One reported joint load on one body: results columns ``<prefix>.F_x`` ..."""

    prefix: str
    joint: str
    body: str


class SystemEquations:
    """The equations of motion of a :class:`~ocp_constraints.mechanics.model.Model`, as SX.

    Attributes (SX): ``q, u, t, inputs``; ``qdot`` (kinematics ``q' = N(q) u``);
    ``mass_matrix``; ``forces`` (applied + gyroscopic); ``G``, ``e`` (constraints,
    ``G u + e = 0``); ``gamma`` (so that ``d(pi)/dt = G u' + gamma``); ``phi`` (the
    position forms of holonomic constraints); ``position_rows`` (``phi`` and each unit
    quaternion's length, :func:`unit_lengths`, of the bodies ``unit_length_bodies`` in that order: what
    a transcription holds at its points); ``energy``.
    """

    def __init__(self, model: Model):
        if not model.bodies:
            raise ModelError(f"model '{model.name}' has no bodies")
        self.model = model
        bodies = list(model.bodies.values())
        self.bodies = bodies
        self.constraints = model.constraints
        self.constraint_names = [c.name for c in self.constraints]
        self.q = ca.vertcat(*[b.q for b in bodies])
        self.u = ca.vertcat(*[b.u for b in bodies])
        self.t = model.t
        self.inputs = model.input_vector
        # Rates of the inputs: needed where an input enters a constraint (a prescribed
        # motion such as a shaft speed Omega(t) chosen by an optimizer).
        self.input_rates = ca.SX.sym("input_rates", self.inputs.numel())
        self.nq, self.nu, self.nc = self.q.numel(), self.u.numel(), len(self.constraints)

        # Point velocity symbols become v_C = vbar + omega x (x_C - xbar) (eq. 8).
        sym, expr = [], []
        for b in bodies:
            for p in b.points.values():
                if p.name != "com":
                    sym.append(p.v)
                    expr.append(p.velocity())
        self._vsym = ca.vertcat(*sym) if sym else ca.SX(0, 1)
        self._vexpr = ca.vertcat(*expr) if expr else ca.SX(0, 1)

        self.qdot = ca.vertcat(*[b.coordinate_rates() for b in bodies])
        self.mass_matrix = ca.diagcat(*[ca.diagcat(b.mass * ca.SX.eye(3), b.inertia_fixed()) for b in bodies])
        self.forces = self._applied_and_gyroscopic(bodies)
        if self.nc:
            pi = self.to_speeds(ca.vertcat(*[c.expression for c in self.constraints]))
            self.G = ca.sparsify(ca.jacobian(pi, self.u))
            self.e = ca.vertcat(*[c.e for c in self.constraints])
            self.gamma = ca.jtimes(pi, self.q, self.qdot) + ca.jacobian(pi, self.t)
            if self.inputs.numel():
                self.gamma += ca.jtimes(pi, self.inputs, self.input_rates)
        else:
            self.G = ca.SX(0, self.nu)
            self.e = self.gamma = ca.SX(0, 1)
        self.holonomic = [i for i, c in enumerate(self.constraints) if c.position is not None]
        self.phi = ca.vertcat(*[self.constraints[i].position for i in self.holonomic]) if self.holonomic else ca.SX(0, 1)
        self.unit_length_bodies = [b.name for b in bodies if isinstance(b.rotation, UnitQuaternion)]
        self.position_rows = ca.vertcat(self.phi, unit_lengths(bodies))
        self.applied_power = self._applied_power()
        g = ca.DM(model.gravity)
        self.kinetic_energy = sum(b.kinetic_energy() for b in bodies)
        self.potential_energy = -sum(b.mass * ca.dot(g, b.xbar) for b in bodies)

    def to_speeds(self, expr: ca.SX) -> ca.SX:
        """Replace point velocity symbols by their expressions in the body speeds."""
        return ca.substitute(expr, self._vsym, self._vexpr) if self._vsym.numel() else expr

    def _applied_and_gyroscopic(self, bodies) -> ca.SX:
        m = self.model
        F = {b.name: ca.DM(m.gravity) * b.mass for b in bodies}
        M = {b.name: -ca.cross(b.omega, b.inertia_fixed() @ b.omega) for b in bodies}
        for pf in m.forces:
            b, f = pf.point.body, self.to_speeds(pf.force)
            F[b.name] = F[b.name] + f
            M[b.name] = M[b.name] + ca.cross(pf.point.position - b.xbar, f)
        for tq in m.torques:
            T = self.to_speeds(tq.torque)
            M[tq.body.name] = M[tq.body.name] + T
            if tq.reaction_body is not None:
                M[tq.reaction_body.name] = M[tq.reaction_body.name] - T
        return ca.vertcat(*[ca.vertcat(F[b.name], M[b.name]) for b in bodies])

    def _applied_power(self) -> ca.SX:
        """Power of the applied loads other than gravity (gravity is in the potential energy)."""
        power = ca.SX(0)
        for pf in self.model.forces:
            power += ca.dot(self.to_speeds(pf.force), pf.point.velocity())
        for tq in self.model.torques:
            omega = tq.body.omega if tq.reaction_body is None else tq.body.omega - tq.reaction_body.omega
            power += ca.dot(self.to_speeds(tq.torque), omega)
        return power

    # -- numeric functions (built once, on first use) --------------------------------
    @cached_property
    def forward_dynamics(self) -> ca.Function:
        """``(q, u, t, inputs, input_rates) -> (u', lambda)`` from the KKT system.

        ``[M, -G^T; G, 0] [u'; lambda] = [f; -gamma]`` is assembled as SX (sparse) and
        solved by CasADi's sparse numerical QR (``linsol``) at evaluation time; the mass
        matrix is never inverted. (A symbolic factorization grows like the cube of the
        system: a 12-body chain needed 7 GB and 35 s; this one takes 160 MB and 0.5 s, and
        is no slower on the small scenes.)
        """
        K = ca.blockcat(self.mass_matrix, -self.G.T, self.G, ca.SX(self.nc, self.nc))
        rhs = ca.vertcat(self.forces, -self.gamma)
        args = [self.q, self.u, self.t, self.inputs, self.input_rates]
        names = ["q", "u", "t", "inputs", "input_rates"]
        parts = ca.Function("kkt_parts", args, [K, rhs])
        margs = [ca.MX.sym(n, a.sparsity()) for n, a in zip(names, args)]
        Km, rm = parts(*margs)
        z = ca.solve(Km, rm, "qr")
        return ca.Function("forward_dynamics", margs, [z[: self.nu], z[self.nu :]], names, ["udot", "lam"])

    @cached_property
    def constraint_functions(self) -> ca.Function:
        """``(q, u, t, inputs) -> (G, e, phi, velocity residual G u + e, d(phi)/dq)``."""
        return ca.Function(
            "constraint_functions", [self.q, self.u, self.t, self.inputs],
            [self.G, self.e, self.phi, self.G @ self.u + self.e, ca.jacobian(self.phi, self.q)],
            ["q", "u", "t", "inputs"], ["G", "e", "phi", "pi", "phi_q"],
        )

    @cached_property
    def position_form_mismatch(self) -> ca.Function:
        """``(q, u, t) -> d(phi)/dt - pi`` for the holonomic constraints (zero on the manifold)."""
        pi = (self.G @ self.u + self.e)[self.holonomic] if self.holonomic else ca.SX(0, 1)
        rate = ca.jtimes(self.phi, self.q, self.qdot) + ca.jacobian(self.phi, self.t)
        return ca.Function("position_form_mismatch", [self.q, self.u, self.t, self.inputs], [rate - pi],
                           ["q", "u", "t", "inputs"], ["mismatch"])

    @cached_property
    def mass_matrix_function(self) -> ca.Function:
        return ca.Function("mass_matrix", [self.q], [self.mass_matrix], ["q"], ["M"])

    @cached_property
    def energy_function(self) -> ca.Function:
        return ca.Function("energy", [self.q, self.u], [self.kinetic_energy, self.potential_energy], ["q", "u"], ["T", "U"])

    @cached_property
    def speeds_from_rates(self) -> ca.Function:
        """``q -> B(q)`` with ``u = B q'`` (block-diagonal over bodies)."""
        B = ca.diagcat(*[b.speeds_from_rates_matrix() for b in self.bodies])
        return ca.Function("speeds_from_rates", [self.q], [B], ["q"], ["B"])

    @cached_property
    def coordinate_rates(self) -> ca.Function:
        return ca.Function("coordinate_rates", [self.q, self.u], [self.qdot], ["q", "u"], ["qdot"])

    @cached_property
    def rate_matrix(self) -> ca.Function:
        """``q -> N(q)`` with ``q' = N(q) u`` (the coordinate rates are linear in the speeds)."""
        return ca.Function("rate_matrix", [self.q], [ca.jacobian(self.qdot, self.u)], ["q"], ["N"])

    # -- constraint loads (built only when results ask for them) -----------------------
    @cached_property
    def load_channels(self) -> list[LoadChannel]:
        out = []
        for j in self.model.joints.values():
            bodies = j.bodies
            for b in bodies:
                prefix = j.name if len(bodies) == 1 else f"{j.name}@{b.name}"
                out.append(LoadChannel(prefix, j.name, b.name))
        return out

    def joint_load_expressions(self, lam: ca.SX) -> list[dict[str, ca.SX]]:
        """Per load channel: ``F``, ``M``, ``point`` (position) and ``power`` (eqs. 26-27)."""
        index = {c.name: k for k, c in enumerate(self.constraints)}
        out = []
        for ch in self.load_channels:
            j = self.model.joints[ch.joint]
            body = self.model.bodies[ch.body]
            point, Fr, Hr = j.share_on(body)
            lj = ca.vertcat(*[lam[index[c.name]] for c in j.constraints])
            F = Fr.T @ lj
            Mo = Hr.T @ lj
            v = self.to_speeds(point.v) if point.name != "com" else body.vbar
            power = ca.dot(F, v) + ca.dot(Mo, body.omega)
            out.append({"F": F, "M": Mo, "point": point.position, "power": power})
        return out

    @cached_property
    def loads_function(self) -> ca.Function:
        """``(q, u, t, lam) -> [F (3), M (3), point (3), power]`` stacked per load channel."""
        lam = ca.SX.sym("lam", self.nc)
        rows = []
        for d in self.joint_load_expressions(lam):
            rows += [d["F"], d["M"], d["point"], d["power"]]
        out = ca.vertcat(*rows) if rows else ca.SX(0, 1)
        return ca.Function("joint_loads", [self.q, self.u, self.t, lam], [out], ["q", "u", "t", "lam"], ["loads"])

    def load_about_function(self, channel: str, point: Point) -> ca.Function:
        """``(q, u, t, lam) -> (F, M_A)``: the joint load moved to ``point`` (eqs. 32-33).

        ``channel`` is a joint name, or ``<joint>@<body>`` for a two-body joint. The force
        is unchanged; the moment gains ``(x_C - x_A) x F``.
        """
        names = [ch.prefix for ch in self.load_channels]
        if channel not in names:
            raise ModelError(f"no joint load '{channel}'; joint loads: {names}")
        lam = ca.SX.sym("lam", self.nc)
        d = self.joint_load_expressions(lam)[names.index(channel)]
        M_A = equipollent_moment(d["F"], d["M"], d["point"], point.position)
        return ca.Function("load_about", [self.q, self.u, self.t, lam], [d["F"], M_A], ["q", "u", "t", "lam"], ["F", "M"])

    def generalized_constraint_forces(self, q, lam, t: float = 0.0, coordinates: ca.Function | None = None) -> np.ndarray:
        """``Phi_Gamma = sum_k lambda_k A_k,Gamma`` (paper eqs. 38-41).

        ``A = G B(q)`` for the bodies' own coordinates, or ``A = G B dq/dp`` for user
        coordinates ``p`` given as ``coordinates: p -> q`` (a CasADi Function); then ``q``
        here is the value of ``p``. Returns ``Phi`` per constraint (rows) and coordinate.
        """
        if coordinates is None:
            qv = np.asarray(q, dtype=float)
            dq_dp = np.eye(self.nq)
        else:
            qv = np.asarray(coordinates(q), dtype=float).ravel()
            dq_dp = np.asarray(self._coordinate_jacobian(coordinates)(q))
        G = np.asarray(self.constraint_functions(qv, np.zeros(self.nu), t, np.zeros(self.inputs.numel()))[0])
        A = G @ np.asarray(self.speeds_from_rates(qv)) @ dq_dp
        return np.asarray(lam, dtype=float).reshape(-1, 1) * A

    def _coordinate_jacobian(self, coordinates: ca.Function) -> ca.Function:
        """``p -> dq/dp``, built once per coordinate map (called per sample in gait work)."""
        cache = self.__dict__.setdefault("_coordinate_jacobians", {})
        key = id(coordinates)
        if key not in cache:
            p = ca.SX.sym("p", coordinates.size1_in(0))
            cache[key] = (coordinates, ca.Function("dq_dp", [p], [ca.jacobian(coordinates(p), p)]))
        return cache[key][1]

    # -- checks -------------------------------------------------------------------------
    def check_redundancy(self, q, t: float = 0.0, tol: float = 1e-9) -> None:
        """Raise :class:`RedundantConstraintsError` naming constraints that repeat others.

        A row of ``G`` that lies in the span of the rows before it is redundant; the
        message names it and the constraints it is a combination of.
        """
        if not self.nc:
            return
        G = np.asarray(self.constraint_functions(q, np.zeros(self.nu), t, np.zeros(self.inputs.numel()))[0])
        G = equilibrated(G.reshape(self.nc, self.nu))[0]      # the rank in no unit, largest entry 1 (scaling.equilibrated)
        if np.linalg.matrix_rank(G, tol=tol) == self.nc:
            # Full row rank: by interlacing, every leading set of rows then is too (no row is redundant);
            # one SVD instead of one per constraint.
            return
        kept: list[int] = []
        problems, drop, alternatives = [], [], []
        for k in range(self.nc):
            rows = G[kept + [k]]
            if np.linalg.matrix_rank(rows, tol=tol) == len(kept) + 1:
                kept.append(k)
                continue
            coef, *_ = np.linalg.lstsq(G[kept].T, G[k], rcond=None) if kept else (np.zeros(0),)
            combo = [self.constraint_names[kept[i]] for i in range(len(kept)) if abs(coef[i]) > 1e-8]
            what = ", ".join(f"'{n}'" for n in combo) if combo else "nothing (its gradient is zero)"
            name = self.constraint_names[k]
            problems.append(f"'{name}' is a combination of {what}")
            drop.append(f"'{name}'")
            alternatives.append(f"'{name}' or one of {what}" if combo else f"'{name}'")
        if problems:
            raise RedundantConstraintsError(
                f"model '{self.model.name}': redundant constraints at t = {t:g}: "
                + "; ".join(problems)
                + f". Drop {', '.join(drop)} (each scalar constraint must restrict a new direction, or the "
                "multipliers are not determined); any one constraint of each combination may go instead: "
                + "; ".join(alternatives) + "."
            )
