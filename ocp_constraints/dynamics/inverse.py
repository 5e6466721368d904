"""Pointwise inverse dynamics: multipliers and actuator inputs from a known motion.

At each sample the Newton-Euler balances (see :mod:`ocp_constraints.mechanics.equations`) are
linear in the unknown multipliers ``lambda`` and actuator inputs ``tau``:

    G^T lambda + B tau = M u' - f(q, u, t, 0) - f_ext,     B = d f / d inputs,

(``f_ext``: optional measured external loads per sample, e.g. ground reactions),
``6 n_bodies`` equations in ``n_constraints + n_inputs`` unknowns. They are solved by
least squares; when over-determined (the motion is not exactly one the model can
produce) the residual norm is reported per sample, never hidden. A rank-deficient
system (redundant constraints, an input that acts like a constraint) is an error.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from ..mechanics.equations import SystemEquations
from ..errors import ModelError
from .result import MechanicalResult


@dataclass
class InverseDynamicsResult(MechanicalResult):
    """Multipliers ``lam`` (samples x constraints), inputs (samples x inputs), residuals (N, N m).

    Keeps the equations and the states (``q``, ``u``, ``udot``, rows are samples) so that
    it answers the common vocabulary (:mod:`.result`): ``sample(name)``, ``loads()``,
    ``load_about(joint, point)``. ``success`` is True (a system that does not determine
    the unknowns raises instead); ``status`` says whether the balances hold exactly
    (``"solved"``) or in the least-squares sense, with the largest residual.
    """

    t: np.ndarray
    lam: np.ndarray
    inputs: np.ndarray
    residual: np.ndarray
    constraint_names: list[str]
    input_names: list[str]
    eqs: SystemEquations = field(repr=False)
    q: np.ndarray = field(repr=False)
    u: np.ndarray = field(repr=False)
    udot: np.ndarray = field(repr=False)
    status: str = "solved"
    success: bool = True

    def mechanical_samples(self):
        return self.eqs, self.t, self.q, self.u, self.lam, self.inputs

    def multiplier(self, name: str) -> np.ndarray:
        if name not in self.constraint_names:
            raise ModelError(f"no constraint '{name}'; constraints: {self.constraint_names}")
        return self.lam[:, self.constraint_names.index(name)]

    def input(self, name: str) -> np.ndarray:
        if name not in self.input_names:
            raise ModelError(f"no input '{name}'; inputs: {self.input_names}")
        return self.inputs[:, self.input_names.index(name)]


EXACT = 1e-9       # relative residual below which the balances count as solved exactly (status "solved")


class InverseDynamics:
    """Builds the linear system once; call :meth:`solve` or :meth:`solve_coordinates`."""

    def __init__(self, eqs: SystemEquations):
        self.eqs = eqs
        B = ca.jacobian(eqs.forces, eqs.inputs)
        if eqs.inputs.numel() and ca.depends_on(B, eqs.inputs):
            raise ModelError(
                f"model '{eqs.model.name}': applied loads must be affine in the inputs for inverse dynamics"
            )

    @cached_property
    def _system(self) -> ca.Function:
        e = self.eqs
        udot = ca.SX.sym("udot", e.nu)
        f0 = ca.substitute(e.forces, e.inputs, ca.SX.zeros(e.inputs.shape))
        A = ca.horzcat(e.G.T, ca.jacobian(e.forces, e.inputs))
        b = e.mass_matrix @ udot - f0
        return ca.Function("inverse_system", [e.q, e.u, udot, e.t], [A, b], ["q", "u", "udot", "t"], ["A", "b"])

    @property
    def linear_system(self) -> ca.Function:
        """``(q, u, u', t) -> (A, b)``: the balances as ``A [lambda; tau] = b``, ``A = [G^T, B]``,
        ``b = M u' - f`` with ``f`` the applied and gyroscopic loads at zero inputs."""
        return self._system

    @cached_property
    def _speeds(self) -> ca.Function:
        """``(q, q', q'') -> (u, u')`` through ``u = B(q) q'``."""
        e = self.eqs
        qd, qdd = ca.SX.sym("qd", e.nq), ca.SX.sym("qdd", e.nq)
        B = ca.diagcat(*[b.speeds_from_rates_matrix() for b in e.bodies])
        u = B @ qd
        udot = B @ qdd + ca.jtimes(u, e.q, qd)
        return ca.Function("speeds", [e.q, qd, qdd], [u, udot])

    def solve(self, t, q, u, udot, external=None) -> InverseDynamicsResult:
        """Samples of speeds ``u`` and their rates ``u'`` (rows are samples).

        ``external`` (optional, samples x ``6 n_bodies``): applied loads known per sample
        (measured ground reactions, ...), per body in model order the force and then the
        moment about its center of mass, fixed basis (the layout of ``u``). They enter the
        balances as applied loads: ``G^T lambda + B tau = M u' - f - f_ext``.
        """
        e = self.eqs
        t = np.atleast_1d(np.asarray(t, float))
        q, u, udot = (np.atleast_2d(np.asarray(a, float)) for a in (q, u, udot))
        arrays = [("q", q, e.nq), ("u", u, e.nu), ("udot", udot, e.nu)]
        if external is not None:
            external = np.atleast_2d(np.asarray(external, float))
            arrays.append(("external", external, e.nu))
        for what, a, n in arrays:
            if a.shape != (len(t), n):
                raise ModelError(f"inverse dynamics: {what} must have shape ({len(t)}, {n}), got {a.shape}")
            if not np.all(np.isfinite(a)):
                row = int(np.argwhere(~np.isfinite(a))[0, 0])
                raise ModelError(f"inverse dynamics: {what} is not finite at sample {row} (t = {t[row]:g})")
        N, n_un = len(t), e.nc + e.inputs.numel()
        A, b = (np.asarray(x) for x in self._system.map(N)(q.T, u.T, udot.T, t[None, :]))
        A = A.reshape(e.nu, N, n_un).transpose(1, 0, 2)          # samples x equations x unknowns
        b = b.T.copy()
        if external is not None:
            b -= external
        rank = np.linalg.matrix_rank(A[0])
        if rank < n_un:
            raise ModelError(
                f"inverse dynamics of '{e.model.name}': multipliers and inputs are not determined "
                f"(rank {rank} < {n_un} unknowns); check for redundant "
                "constraints (SystemEquations.check_redundancy) or inputs acting along a constraint"
            )
        if A.shape[1] == n_un:
            x = np.linalg.solve(A, b[:, :, None])[:, :, 0]
        else:
            x = np.einsum("nij,nj->ni", np.linalg.pinv(A), b)      # least squares, per sample
        res = np.linalg.norm(np.einsum("nij,nj->ni", A, x) - b, axis=1)
        worst = float(res.max(initial=0.0))
        exact = worst <= EXACT * max(1.0, float(np.abs(b).max(initial=0.0)))
        status = "solved" if exact else f"least squares: largest equation residual {worst:.3g} (N, N m)"
        return InverseDynamicsResult(t, x[:, : e.nc], x[:, e.nc :], res, e.constraint_names, list(e.model.inputs),
                                     e, q, u, udot, status)

    def solve_coordinates(self, t, q, qdot, qddot, external=None) -> InverseDynamicsResult:
        """Samples of coordinates and their first and second time derivatives (``external``: see :meth:`solve`)."""
        t = np.atleast_1d(np.asarray(t, float))
        q, qdot, qddot = (np.atleast_2d(np.asarray(a, float)) for a in (q, qdot, qddot))
        U = [self._speeds(a, b, c) for a, b, c in zip(q, qdot, qddot)]
        u = np.array([np.asarray(x[0]).ravel() for x in U])
        udot = np.array([np.asarray(x[1]).ravel() for x in U])
        return self.solve(t, q, u, udot, external)
