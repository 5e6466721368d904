"""A consistent start in joint coordinates, from the user's guesses on the bodies' names.

The recipe of :mod:`.guess` (paper sec. 5: the motion on the constraints, loads from the
balances), done in joint coordinates at all collocation points at once:

1. joint coordinates fitted (Gauss-Newton, least squares) to the body coordinates the user
   guessed or fixed at an end (linear between the boundary values); coordinates with neither
   take no part; then moved onto the remaining position forms ``phi_r(p, t) = 0``;
2. speeds: the user's speed guesses, else linear between the boundary speeds (0 where none is
   given), carried to ``u_r`` nearest in the kinetic-energy metric with ``G_r u_r + e_r = 0``;
3. accelerations: the time derivative of those speeds (the scheme's, where it derives them);
4. remaining multipliers and inputs: pointwise inverse dynamics ``G_r^T lambda_r + B_r w =
   M_r u_r' - f_r(w = 0)`` (least squares, smallest norm), the user's input guesses kept and
   the inputs clipped to their bounds.

The joints' constraints hold by construction, so nothing is projected for them: the maximal
form's per-point projections (most of its start's cost) are not needed.
"""
from __future__ import annotations

from functools import cached_property

import casadi as ca
import numpy as np


class JointGuess:
    """The start's pieces for one :class:`~ocp_constraints.mechanics.generalized.JointCoordinates`."""

    def __init__(self, reduced):
        self.r = reduced

    @cached_property
    def _functions(self) -> dict:
        r = self.r
        lam = r.multiplier_symbols[1]
        a = ca.SX.sym("a", r.nu)
        z = ca.vertcat(lam, r.inputs)
        residual = r.mass_matrix @ a - r.forces - r.G.T @ lam
        zero = ca.substitute(residual, z, ca.DM.zeros(z.numel()))
        phi_q = ca.jacobian(r.phi, r.q)
        return {
            "pose": ca.Function("pose", [r.q], [r.q_full, ca.jacobian(r.q_full, r.q)]),
            "phi": ca.Function("phi", [r.q, r.t, r.inputs], [r.phi, phi_q]),
            "metric": ca.Function("metric", [r.q, r.t, r.inputs],
                                  [r.J.T @ r.M_full @ r.J, r.J.T @ r.M_full, r.G, r.e]),
            "balance": ca.Function("balance", [r.q, r.u, a, r.t, r.inputs], [ca.jacobian(residual, z), -zero]),
        }

    def coordinates(self, targets: np.ndarray, t: np.ndarray) -> np.ndarray:
        """``p`` (``nq_r x P``) nearest the body-coordinate ``targets`` (NaN: no target), on ``phi_r = 0``."""
        r, P = self.r, targets.shape[1]
        pose = self._functions["pose"].map(P)
        p = np.repeat(r.reference_point()[:, None], P, axis=1)
        mask = ~np.isnan(targets)
        goal = np.nan_to_num(targets)
        for _ in range(30):
            q, dq = pose(p)
            dq = np.asarray(dq).reshape(-1, P, r.nq).transpose(1, 0, 2) * mask.T[:, :, None]
            step = (np.linalg.pinv(dq) @ ((goal - np.asarray(q)) * mask).T[:, :, None])[:, :, 0].T
            p = p + step
            if np.abs(step).max() < 1e-12 * (1 + np.abs(p).max()):
                break
        if r.phi.numel():
            p = self._onto_constraints(p, pose, mask, goal, t)
        return p

    def _onto_constraints(self, p, pose, mask, goal, t, weight: float = 1e3) -> np.ndarray:
        """Levenberg-Marquardt on ``weight^2 |phi_r(p)|^2 + |mask (q(p) - goal)|^2`` point by point (the
        feasible pose nearest the guess: a loop closure is met by the unguessed joints first), then
        minimum-norm Gauss-Newton steps on ``phi_r = 0`` alone, to round-off."""
        r, P = self.r, p.shape[1]
        phi = self._functions["phi"].map(P)
        w0 = np.zeros((r.inputs.numel(), P))

        def residual(p):
            value, jac = (np.asarray(v) for v in phi(p, t[None, :], w0))
            q, dq = pose(p)
            R = np.vstack([weight * value, (np.asarray(q) - goal) * mask])
            J = np.concatenate([weight * jac.reshape(-1, P, r.nq),
                                np.asarray(dq).reshape(-1, P, r.nq) * mask[:, :, None]]).transpose(1, 0, 2)
            return R, J, value, jac.reshape(-1, P, r.nq).transpose(1, 0, 2)

        R, J, _, _ = residual(p)
        cost, mu = (R**2).sum(axis=0), np.full(P, 1e-3)
        eye = np.eye(r.nq)
        for _ in range(100):
            H = np.transpose(J, (0, 2, 1)) @ J + mu[:, None, None] * eye
            step = -np.linalg.solve(H, np.transpose(J, (0, 2, 1)) @ R.T[:, :, None])[:, :, 0].T
            R1, J1, _, _ = residual(p + step)
            cost1 = (R1**2).sum(axis=0)
            better = cost1 < cost
            p = np.where(better, p + step, p)
            R, J = np.where(better, R1, R), np.where(better[:, None, None], J1, J)
            cost, mu = np.where(better, cost1, cost), np.where(better, mu * 0.3, mu * 10.0)
            if np.abs(step).max() < 1e-12 * (1 + np.abs(p).max()):
                break
        for _ in range(10):
            _, _, value, jac = residual(p)
            if np.abs(value).max() < 1e-14:
                break
            p = p - (np.linalg.pinv(jac) @ value.T[:, :, None])[:, :, 0].T
        return p

    def speeds(self, p: np.ndarray, targets: np.ndarray, t: np.ndarray, W: np.ndarray) -> np.ndarray:
        """``u_r`` nearest (kinetic-energy metric) to the body speeds ``targets``, with ``G_r u_r + e_r = 0``."""
        r, P = self.r, p.shape[1]
        Mr, JtM, G, e = (np.asarray(v) for v in self._functions["metric"].map(P)(p, t[None, :], W))
        Mr = Mr.reshape(r.nu, P, r.nu).transpose(1, 0, 2)
        rhs = np.einsum("pij,jp->pi", JtM.reshape(r.nu, P, -1).transpose(1, 0, 2), targets)
        if not r.nc:
            return (np.linalg.pinv(Mr) @ rhs[:, :, None])[:, :, 0].T
        G = G.reshape(r.nc, P, r.nu).transpose(1, 0, 2)
        K = np.block([[Mr, np.transpose(G, (0, 2, 1))], [G, np.zeros((P, r.nc, r.nc))]])
        b = np.concatenate([rhs, -e.reshape(r.nc, P).T], axis=1)
        return (np.linalg.pinv(K) @ b[:, :, None])[:, : r.nu, 0].T

    def loads(self, p, U, A, t, W_user: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Remaining multipliers and inputs from the balances (least squares, user inputs kept)."""
        r, P = self.r, p.shape[1]
        n_in = r.inputs.numel()
        Z, b = (np.asarray(v) for v in self._functions["balance"].map(P)(p, U, A, t[None, :], np.zeros((n_in, P))))
        Z = Z.reshape(r.nu, P, r.nc + n_in).transpose(1, 0, 2)
        b = b.reshape(r.nu, P)
        L, W = np.zeros((r.nc, P)), np.nan_to_num(W_user).copy()
        given = ~np.isnan(W_user)
        for i in range(P):
            keep = np.concatenate([np.ones(r.nc, bool), ~given[:, i]])
            rhs = b[:, i] - Z[i][:, r.nc:][:, given[:, i]] @ W_user[given[:, i], i]
            z = np.linalg.lstsq(Z[i][:, keep], rhs, rcond=None)[0]
            L[:, i] = z[: r.nc]
            W[~given[:, i], i] = z[r.nc:]
        return L, W
