"""Accelerations and multipliers of one point as SX expressions of its state: the pointwise KKT solve.

The equations of motion (paper eq. 13 with the prescribed loads of eq. 26, in the form of
:class:`~ocp_constraints.mechanics.equations.SystemEquations`)

    M(q) u' = f(q, u, t, w) + G^T lambda,        G u' + gamma(q, u, t) = 0   (d(pi)/dt = 0, eq. 25)

give ``u'`` and ``lambda`` as functions of ``(q, u, t, w)``. ``M = diag(m_b I, Q_b J_b Q_b^T)`` is
block-diagonal per body, so where every body's inertia tensor is invertible its inverse is written
per body, ``M^-1 = diag(I / m_b, Q_b J_b^-1 Q_b^T)``, and only the Schur complement
``S = G M^-1 G^T`` (one row and column per constraint) is solved symbolically:

    lambda = -S^-1 (G M^-1 f + gamma),        u' = M^-1 (f + G^T lambda).

A body with a singular inertia tensor (a thin rod has no moment about its axis: its ``M`` is
singular, the constraints make the KKT matrix regular) takes the whole KKT matrix instead,
``[M, -G^T; G, 0] [u'; lambda] = [f; -gamma]``. Both are SX (CasADi's symbolic QR): the point
elements of the NLP are SX functions differentiated symbolically (:mod:`.nlp_assembly`).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ModelError


@dataclass
class PointwiseKKT:
    """``a = u'`` and ``lam`` as SX expressions of the equations' ``q, u, t, inputs``, and how a slack
    ``s`` (one entry per constraint) moves them: ``u' = a + da @ s``, ``lambda = lam + dlam @ s``.

    With ``s`` free the acceleration-level constraint ``G u' + gamma = 0`` no longer holds, the
    balance ``M u' = f + G^T lambda`` still does: the velocity-level slack of the condensed
    transcription. Block-diagonal inverse: ``s`` is the multipliers' change (``da = M^-1 G^T``,
    ``dlam = I``); whole KKT matrix: ``s`` is the residual ``G u' + gamma`` (``[da; dlam] = K^-1 [0; I]``).
    ``schur``: whether the block-diagonal inverse was used.
    """

    a: ca.SX
    lam: ca.SX
    da: ca.SX
    dlam: ca.SX
    schur: bool


def driven_constraints(eqs) -> list[str]:
    """Constraints whose velocity form depends on an input (their acceleration level needs its rate)."""
    if not (eqs.nc and eqs.inputs.numel()):
        return []
    pi = eqs.G @ eqs.u + eqs.e
    return [eqs.constraint_names[k] for k in range(eqs.nc) if ca.depends_on(pi[k], eqs.inputs)]


def pointwise_kkt(eqs) -> PointwiseKKT:
    """The KKT solution of ``eqs`` (a :class:`SystemEquations`) as SX expressions, one block per body.

    A body whose inertia tensor ``J`` is singular (a thin rod: nothing about its axis ``d``) gets
    ``J~ = J + c d d^T`` and an unknown ``beta = n . omega'`` per null direction ``n = Q d``:
    ``(M + c N N^T) u' = f + G^T lambda + c N beta`` is the balance again, and
    ``N^T u' = beta`` closes it. ``M~ = M + c N N^T`` stays block-diagonal with the analytic inverse
    ``diag(I / m, Q J~^-1 Q^T)``, so only ``[G; N^T] M~^-1 [G^T, c N] - diag(0, I)`` (one row per
    constraint and null direction) is solved symbolically, never the whole KKT matrix.
    Raises :class:`ModelError` naming the constraints whose velocity form depends on an input: their
    acceleration level needs the input's rate, which the condensed transcription does not have.
    """
    driven = driven_constraints(eqs)
    if driven:
        raise ModelError(f"constraints {driven} of model '{eqs.model.name}' depend on an input (a prescribed "
                         f"motion chosen by the optimizer); the condensed transcription needs the input's rate "
                         f"there: use coordinates='maximal'")
    f, G, nu, nc = eqs.forces, eqs.G, eqs.nu, eqs.nc
    # No input enters a constraint (checked above): the input rates' symbols are absent from gamma.
    gamma = eqs.gamma if nc else ca.SX(0, 1)
    Minv, N, c = _regular_blocks(eqs)
    ns = N.size2()
    if not ns:
        if not nc:
            return PointwiseKKT(Minv @ f, ca.SX(0, 1), ca.SX(nu, 0), ca.SX(0, 0), True)
        MinvGt = ca.sparsify(Minv @ G.T)
        lam = -ca.solve(G @ MinvGt, G @ (Minv @ f) + gamma)
        return PointwiseKKT(Minv @ f + MinvGt @ lam, lam, MinvGt, ca.SX.eye(nc), True)
    B = ca.horzcat(G.T, N)                 # N's columns carry the factor c already
    R = ca.vertcat(G, ca.diag(ca.DM(1.0 / c)) @ N.T)     # rows n^T u' = beta
    S = R @ ca.sparsify(Minv @ B) - ca.diagcat(ca.SX(nc, nc), ca.SX.eye(ns))
    rhs = -(R @ (Minv @ f) + ca.vertcat(gamma, ca.SX(ns, 1)))
    # One symbolic factorization for the solution and for the slack directions [G; N^T] u' = (s, 0).
    Y = ca.solve(S, ca.horzcat(rhs, ca.vertcat(ca.SX.eye(nc), ca.SX(ns, nc))))
    a = Minv @ (f + B @ Y[:, 0])
    return PointwiseKKT(a, Y[:nc, 0], Minv @ B @ Y[:, 1:], Y[:nc, 1:], False)


def _regular_blocks(eqs, rtol: float = 1e-12) -> tuple[ca.SX, ca.SX, np.ndarray]:
    """``(M~^-1, c N, c)``: the block-diagonal inverse of ``M~ = M + c N N^T``, the null directions
    ``n = Q d`` of the singular inertia tensors (columns, scaled by ``c``, in the rows of their ``omega``)
    and each column's ``c``."""
    blocks, columns, scales, offset = [], [], [], 0
    for b in eqs.bodies:
        J = np.asarray(b.inertia, float)
        w, V = np.linalg.eigh(J)
        c = max(w.max(), b.mass * 1e-6)       # any c > 0 is exact; the body's own scale keeps M~ well conditioned
        null = V[:, w <= rtol * max(w.max(), 1e-300)]
        Jt = J + c * null @ null.T
        blocks += [ca.SX.eye(3) / b.mass, b.Q @ ca.DM(np.linalg.inv(Jt)) @ b.Q.T]
        for d in null.T:
            col = ca.SX(eqs.nu, 1)
            col[offset + 3 : offset + 6] = c * (b.Q @ ca.DM(d))
            columns.append(col)
            scales.append(c)
        offset += 6
    return ca.diagcat(*blocks), ca.horzcat(*columns) if columns else ca.SX(eqs.nu, 0), np.array(scales)
