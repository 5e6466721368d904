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


def pointwise_kkt(eqs, *, condition_limit: float = 1e12) -> PointwiseKKT:
    """The KKT solution of ``eqs`` (a :class:`SystemEquations`) as SX expressions.

    A body whose inertia tensor is singular (a thin rod) is made regular by its own constraints:
    with ``G_1`` the rows of ``G`` that act on that body alone, ``G_1 u' = -gamma_1`` turns its
    balance into ``(M_b + G_1^T G_1) u' = f + G^T lambda - G_1^T gamma_1``, still one block per body.
    Where that is not enough (a singular body held only through other bodies) the whole KKT matrix is
    solved. Raises :class:`ModelError` naming the constraints whose velocity form depends on an input:
    their acceleration level needs the input's rate, which the condensed transcription does not have.
    """
    driven = driven_constraints(eqs)
    if driven:
        raise ModelError(f"constraints {driven} of model '{eqs.model.name}' depend on an input (a prescribed "
                         f"motion chosen by the optimizer); the condensed transcription needs the input's rate "
                         f"there: use coordinates='maximal'")
    f, G, nu, nc = eqs.forces, eqs.G, eqs.nu, eqs.nc
    # No input enters a constraint (checked above): the input rates' symbols are absent from gamma.
    gamma = eqs.gamma if nc else ca.SX(0, 1)
    blocks = _regular_blocks(eqs, condition_limit)
    if blocks is None:
        K = ca.blockcat(eqs.mass_matrix, -G.T, G, ca.SX(nc, nc))
        # One symbolic factorization for both right-hand sides.
        Z = ca.solve(K, ca.horzcat(ca.vertcat(f, -gamma), ca.vertcat(ca.SX(nu, nc), ca.SX.eye(nc))))
        return PointwiseKKT(Z[:nu, 0], Z[nu:, 0], Z[:nu, 1:], Z[nu:, 1:], False)
    Minv, rows = blocks
    if not nc:
        return PointwiseKKT(Minv @ f, ca.SX(0, 1), ca.SX(nu, 0), ca.SX(0, 0), True)
    E1 = ca.SX(nc, len(rows))
    for j, k in enumerate(rows):
        E1[k, j] = 1
    G1 = G[rows, :] if rows else ca.SX(0, nu)
    rhs = f - G1.T @ gamma[rows] if rows else f
    MinvGt = ca.sparsify(Minv @ G.T)
    lam = -ca.solve(G @ MinvGt, G @ (Minv @ rhs) + gamma)
    a = Minv @ rhs + MinvGt @ lam
    # lambda + mu moves u' by M~^-1 G^T mu; the G_1 rows' share taken back so that M u' = f + G^T lambda.
    dlam = ca.SX.eye(nc) - E1 @ (G1 @ MinvGt) if rows else ca.SX.eye(nc)
    return PointwiseKKT(a, lam, MinvGt, dlam, True)


def _regular_blocks(eqs, condition_limit: float):
    """``(M~^-1, rows)``: the block-diagonal inverse of ``M~ = M + G_1^T G_1`` and the rows ``G_1``
    (single-body constraints on bodies with a singular inertia tensor), or None where some block stays singular."""
    G, offset = eqs.G, 0
    blocks, rows = [], []
    for b in eqs.bodies:
        cols = list(range(offset, offset + 6))
        offset += 6
        if np.linalg.cond(b.inertia) < condition_limit:
            blocks += [ca.SX.eye(3) / b.mass, b.Q @ ca.DM(np.linalg.inv(b.inertia)) @ b.Q.T]
            continue
        own = [k for k in range(eqs.nc) if _touches_only(G, k, cols)]
        Mb = ca.diagcat(b.mass * ca.SX.eye(3), b.inertia_fixed())
        if own:
            Gb = G[own, cols]
            Mb = Mb + Gb.T @ Gb
        Mb_value = ca.Function("Mb", [eqs.q], [Mb])(np.random.default_rng(0).uniform(-0.7, 0.7, eqs.nq))
        if np.linalg.cond(np.asarray(Mb_value)) > condition_limit:
            return None
        blocks.append(ca.solve(Mb, ca.SX.eye(6)))
        rows += own
    return ca.diagcat(*blocks), sorted(rows)


def _touches_only(G: ca.SX, k: int, cols: list[int]) -> bool:
    """Row ``k`` of ``G`` is structurally nonzero only in ``cols`` (and somewhere there)."""
    nz = [c for c in range(G.size2()) if G[k, c].nnz() and not G[k, c].is_zero()]
    return bool(nz) and set(nz) <= set(cols)
