"""Pointwise inverse dynamics: multipliers and actuator inputs from a known motion.

At each sample the Newton-Euler balances (see :mod:`ocp_constraints.mechanics.equations`) are
linear in the unknown multipliers ``lambda`` and actuator inputs ``tau``:

    G^T lambda + B tau = M u' - f(q, u, t, 0) - f_ext,     B = d f / d inputs,

(``f_ext``: optional measured external loads per sample, e.g. ground reactions),
``6 n_bodies`` equations in ``n_constraints + n_inputs`` unknowns. They are solved by
least squares; when over-determined (the motion is not exactly one the model can
produce) the residual norm is reported per sample, never hidden. A rank-deficient
system (redundant constraints, an input that acts like a constraint) is an error.

Vectorised: when ``A`` is square and structurally nonsingular (a tree of joints, each with
as many directions as its child body has freedoms: every OpenSim model), ``A`` permuted to
its block triangular form (Dulmage-Mendelsohn, :meth:`casadi.Sparsity.btf`) is solved block
by block, symbolically (blocks of 1-3 unknowns for a gait model). The solution is then one
SX function of the sample, ``Function.map``-ped over all samples and evaluated once: no
Python loop per sample, no dense ``samples x 6n x 6n`` array.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np

from ..mechanics.equations import SystemEquations
from ..mechanics.fast_eval import evaluate
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
MAX_BLOCK = 12     # largest diagonal block solved symbolically (a 12x12 QR is ~2,000 operations per sample)


def block_triangular_solve(A: ca.SX, b: ca.SX) -> ca.SX | None:
    """``x`` with ``A x = b`` as an SX expression, through ``A``'s block triangular form, or None.

    None when ``A`` is not square, is structurally singular (``sprank < n``) or has a
    diagonal block larger than :data:`MAX_BLOCK` (the caller then solves numerically).
    Each diagonal block is solved by CasADi's symbolic QR (a 1x1 block by division) after
    the blocks already solved are moved to the right-hand side, so the expression holds
    only the structural nonzeros of ``A`` (the balances of eq. 13, body by body, outward in).
    """
    n = A.size1()
    if A.size2() != n or n == 0 or ca.sprank(A.sparsity()) < n:
        return None
    nblk, rp, cp, rb, cb, _, _ = A.sparsity().btf()
    if max(np.diff(rb)) > MAX_BLOCK or list(rb) != list(cb):
        return None
    Ap, bp = A[rp, cp], b[rp]
    pattern = np.array(ca.DM(Ap.sparsity(), 1)) != 0
    blocks = [(rb[k], rb[k + 1]) for k in range(nblk)]
    if all(not pattern[r0:r1, r1:].any() for r0, r1 in blocks):          # block lower: first block first
        order = blocks
    elif all(not pattern[r0:r1, :r0].any() for r0, r1 in blocks):        # block upper: last block first
        order = blocks[::-1]
    else:
        return None
    xp: list = [None] * n
    for r0, r1 in order:
        rhs = bp[r0:r1]
        known = [c for c in range(n) if xp[c] is not None and pattern[r0:r1, c].any()]
        if known:
            rhs = rhs - Ap[r0:r1, known] @ ca.vertcat(*[xp[c] for c in known])
        x = rhs / Ap[r0, r0] if r1 - r0 == 1 else ca.solve(Ap[r0:r1, r0:r1], rhs)
        for k in range(r1 - r0):
            xp[r0 + k] = x[k]
    out = [None] * n
    for k, c in enumerate(cp):
        out[c] = xp[k]
    return ca.vertcat(*out)


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
    def solution(self) -> ca.Function | None:
        """``(q, u, u', t, f_ext) -> (lambda, tau, residual)`` for one sample, or None.

        The balances ``G^T lambda + B tau = M u' - f - f_ext`` (eq. 13) solved symbolically by
        :func:`block_triangular_solve`; ``residual`` is the 2-norm of the balances at the
        solution (N, N m). None where the system is not square and structurally nonsingular
        (then :meth:`solve` solves each sample by least squares).
        """
        e = self.eqs
        udot, fext = ca.SX.sym("udot", e.nu), ca.SX.sym("f_ext", e.nu)
        A, b = self._system(e.q, e.u, udot, e.t)
        b = b - fext
        x = block_triangular_solve(A, b)
        if x is None:
            return None
        res = ca.norm_2(A @ x - b)
        return ca.Function("inverse_solution", [e.q, e.u, udot, e.t, fext], [x[: e.nc], x[e.nc :], res],
                           ["q", "u", "udot", "t", "f_ext"], ["lam", "tau", "residual"])

    @cached_property
    def _speeds(self) -> ca.Function:
        """``(q, q', q'') -> (u, u')`` through ``u = B(q) q'``."""
        e = self.eqs
        qd, qdd = ca.SX.sym("qd", e.nq), ca.SX.sym("qdd", e.nq)
        B = ca.diagcat(*[b.speeds_from_rates_matrix() for b in e.bodies])
        u = B @ qd
        udot = B @ qdd + ca.jtimes(u, e.q, qd)
        return ca.Function("speeds", [e.q, qd, qdd], [u, udot])

    def check_determined(self, q0, u0, t0: float = 0.0) -> None:
        """Raise if multipliers and inputs are not determined at one sample (rank of ``A``)."""
        e = self.eqs
        n_un = e.nc + e.inputs.numel()
        A = evaluate(self._system, np.reshape(q0, (e.nq, 1)), np.reshape(u0, (e.nu, 1)), np.zeros((e.nu, 1)),
                     np.full((1, 1), float(t0)))[0]
        rank = np.linalg.matrix_rank(A)
        if rank < n_un:
            raise ModelError(
                f"inverse dynamics of '{e.model.name}': multipliers and inputs are not determined "
                f"(rank {rank} < {n_un} unknowns); check for redundant "
                "constraints (SystemEquations.check_redundancy) or inputs acting along a constraint"
            )

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
        N = len(t)
        fext = np.zeros((N, e.nu)) if external is None else external
        self.check_determined(q[0], u[0], t[0])
        if self.solution is not None:       # one mapped evaluation over all samples
            lam, tau, res = evaluate(self.solution.map(N), q.T, u.T, udot.T, t[None, :], fext.T)
            x = np.vstack([lam, tau]).T
            res = res.ravel()
            # a block singular at some sample (the rank check saw the first only); the residual
            # cannot tell (CasADi simplifies a (b / a) - b to 0), the solution can
            bad = ~np.isfinite(x).all(axis=1)
            if bad.any():
                n = int(np.flatnonzero(bad)[0])
                raise ModelError(f"inverse dynamics of '{e.model.name}': the balances are singular at sample {n} "
                                 f"(t = {t[n]:g}): multipliers and inputs are not determined there; check for a "
                                 "joint at a singular configuration or constraints that become redundant")
            scale = 0.0
            if res.max(initial=0.0) > EXACT:    # the balances' scale, only needed to judge a residual
                b = evaluate(self._system.map(N), q.T, u.T, udot.T, t[None, :])[1].T - fext
                scale = float(np.abs(b).max(initial=0.0))
        else:                               # not square: least squares per sample
            x, res, scale = self._least_squares(t, q, u, udot, fext)
        worst = float(res.max(initial=0.0))
        exact = worst <= EXACT * max(1.0, scale)
        status = "solved" if exact else f"least squares: largest equation residual {worst:.3g} (N, N m)"
        return InverseDynamicsResult(t, x[:, : e.nc], x[:, e.nc :], res, e.constraint_names, list(e.model.inputs),
                                     e, q, u, udot, status)

    def _least_squares(self, t, q, u, udot, fext):
        e = self.eqs
        N, n_un = len(t), e.nc + e.inputs.numel()
        A, b = evaluate(self._system.map(N), q.T, u.T, udot.T, t[None, :])
        A = A.reshape(e.nu, N, n_un).transpose(1, 0, 2)          # samples x equations x unknowns
        b = b.T - fext
        if A.shape[1] == n_un:
            x = np.linalg.solve(A, b[:, :, None])[:, :, 0]
        else:
            x = np.einsum("nij,nj->ni", np.linalg.pinv(A), b)      # least squares, per sample
        res = np.linalg.norm(np.einsum("nij,nj->ni", A, x) - b, axis=1)
        return x, res, float(np.abs(b).max(initial=0.0))

    def solve_coordinates(self, t, q, qdot, qddot, external=None) -> InverseDynamicsResult:
        """Samples of coordinates and their first and second time derivatives (``external``: see :meth:`solve`)."""
        t = np.atleast_1d(np.asarray(t, float))
        q, qdot, qddot = (np.atleast_2d(np.asarray(a, float)) for a in (q, qdot, qddot))
        u, udot = (a.T for a in evaluate(self._speeds.map(len(q)), q.T, qdot.T, qddot.T))
        return self.solve(t, q, u, udot, external)
