"""A consistent start for IPOPT from whatever guess the user gave (any subset of coordinates, or none).

At every collocation point (paper sec. 5: the motion on the constraints, loads from the balances):

1. coordinates: the user's guesses, else linear between the boundary values, projected onto
   ``phi(q, t) = 0``;
2. speeds: the user's speed guesses, else linear between the boundary speeds, moved onto
   ``G u + e = 0`` (nearest in the kinetic-energy metric);
3. accelerations: the time derivative of those speeds (the scheme's, where it derives them);
4. multipliers and inputs: pointwise inverse dynamics ``G^T lambda + B tau = M u' - f`` (least
   squares, smallest norm), the user's input guesses kept and the inputs clipped to their bounds.

So iteration 0 has no constraint defect and, where the guessed motion is one the inputs can
produce, no dynamics defect either.
"""
from __future__ import annotations

import numpy as np

from ..dynamics.inverse import InverseDynamics
from ..errors import ModelError
from ..mechanics.state import project_positions, project_speeds
from .diagnostics import unit_quaternions



def consistent_guess(tr, X: np.ndarray, W: np.ndarray, t_final: float) -> tuple[np.ndarray, ...]:
    """``(X, A, L, W)`` blocks (``nx x P``, ``nu x P``, ``nc x P``, ``n_in x P``) for transcription ``tr``.

    ``X`` holds the coordinate guesses (speed rows: the user's speed guesses or NaN) and ``W``
    the input guesses (NaN where the user gave none).
    """
    e, pr = tr.eqs, tr.problem
    t = tr.fractions * t_final
    P, nq = len(t), e.nq
    W0 = np.nan_to_num(W)
    Q = _positions(tr, X[:nq], t, W0)
    U = _speeds(tr, Q, X[nq:], t, W0)
    A = np.gradient(U, t, axis=1) if P > 1 else np.zeros_like(U)
    # The accelerations the NLP will see: where the scheme derives them from the speeds, those.
    A = tr.accelerations(np.vstack([Q, U]), A[:, : tr.layout.n_acc], t_final)
    L, W = _loads(tr, Q, U, A, t, W)
    for r, name in enumerate(pr.model.inputs):
        lo, hi = pr.bounds.get(name, (-np.inf, np.inf))
        W[r] = np.clip(W[r], lo, hi)
    return np.vstack([Q, U]), A, L, W


def _positions(tr, Q_guess: np.ndarray, t: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Coordinates on ``phi(q, t) = 0`` at every point, in time order, each point's found by
    Gauss-Newton steps (at most 0.5 long) that move the coordinates with boundary values 1000x less
    than the others (weighted minimum-norm), then polished by :func:`project_positions` (unit quaternions).

    Coordinates that neither a guess nor a boundary value sets start from the previous point's
    (continuation), so a closed loop stays on one assembly branch. Measured on a driven four-bar
    (crank angle 0 -> 2 pi, rocker guessed upright, Radau 3, N = 20): the plain minimum-norm
    projection from the origin moved the crank off its boundary value (0.22 rad at t = 0) and
    jumped between branches half-way, and IPOPT ended infeasible after 1,154 iterations.
    """
    e, pr = tr.eqs, tr.problem
    names = pr.model.coordinate_names
    held = np.array([n in pr.initial_values or n in pr.final_values for n in names], bool)
    own = held | np.array([n in pr.guess for n in names], bool)
    scale = np.where(held, 1e-3, 1.0)
    parts = _constraint_jacobian(e) if e.phi.numel() else None
    Q, previous = np.array(Q_guess, float), None
    for i in np.argsort(t, kind="stable"):
        q = Q[:, i]
        if previous is not None:
            q[~own] = previous[~own]
        unit_quaternions(e, q)     # an unset quaternion guesses 0, which is no rotation
        for _ in range(30 if parts is not None else 0):
            phi, J = (np.asarray(v, float) for v in parts(q, t[i], W[:, i]))
            if not np.all(np.isfinite(phi)) or np.abs(phi).max() < 1e-12:
                break
            step = scale * np.linalg.lstsq(J * scale, phi.ravel(), rcond=None)[0]
            # Steps of at most 0.5 (rad or m): a full step from far away lands on angles tens of
            # radians off (the same pose, but the next points and the dynamics see the jump).
            q = q - step * min(1.0, 0.5 / max(np.abs(step).max(), 1e-300))
        Q[:, i] = previous = project_positions(e, q, t[i], inputs=W[:, i])
    return Q


def _constraint_jacobian(e):
    """``(q, t, inputs) -> (phi, d(phi)/dq)``, built once per model."""
    if "_guess_phi_jacobian" not in e.__dict__:
        import casadi as ca

        e.__dict__["_guess_phi_jacobian"] = ca.Function("phi_jacobian", [e.q, e.t, e.inputs],
                                                        [e.phi, ca.jacobian(e.phi, e.q)])
    return e.__dict__["_guess_phi_jacobian"]


def _speeds(tr, Q: np.ndarray, U_user: np.ndarray, t: np.ndarray, W: np.ndarray) -> np.ndarray:
    """The user's speed guesses, else linear between the boundary speeds (0 where none is given),
    each point's made consistent: the speeds nearest to them in the kinetic-energy metric with
    ``G u + e = 0`` (:func:`~ocp_constraints.mechanics.state.project_speeds`).

    Measured against speeds fitted to the guessed coordinates' time derivative: that start cost
    the rolling disk (nonholonomic: a straight-line guess of its position is no rolling motion)
    453 IPOPT iterations at Radau 3, N = 20 instead of 243, and the swing-up 15 instead of 9.
    """
    pr, e = tr.problem, tr.eqs
    U = np.array(U_user, float)
    for r, name in enumerate(e.model.speed_names):
        if np.isnan(U[r]).any():
            a = pr.initial_values.get(name, pr.final_values.get(name, 0.0))
            b = pr.final_values.get(name, a)
            U[r] = np.where(np.isnan(U[r]), a + (b - a) * tr.fractions, U[r])
    return np.column_stack([project_speeds(e, Q[:, i], U[:, i], t[i], W[:, i]) for i in range(len(t))])


def _loads(tr, Q, U, A, t, W_user) -> tuple[np.ndarray, np.ndarray]:
    """Multipliers and inputs from the balances at every point; zeros where they cannot be had."""
    e = tr.eqs
    P, n_in = len(t), e.inputs.numel()
    L, W = np.zeros((e.nc, P)), np.nan_to_num(W_user).copy()
    try:
        system = InverseDynamics(e).linear_system
    except ModelError:          # inputs not affine in the loads: no pointwise inverse dynamics
        return L, W
    Asys, b = (np.asarray(x) for x in system.map(P)(Q[: e.nq], U, A, t[None, :]))
    Asys = Asys.reshape(e.nu, P, e.nc + n_in).transpose(1, 0, 2)
    b = b.reshape(e.nu, P)
    given = ~np.isnan(W_user)
    for i in range(P):
        keep = np.concatenate([np.ones(e.nc, bool), ~given[:, i]])
        rhs = b[:, i] - Asys[i][:, e.nc:][:, given[:, i]] @ W_user[given[:, i], i]
        z = np.linalg.lstsq(Asys[i][:, keep], rhs, rcond=None)[0]
        L[:, i] = z[: e.nc]
        W[~given[:, i], i] = z[e.nc:]
    return L, W


def from_solution(tr, solution) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States, multipliers and inputs at ``tr``'s points from a solution of the same problem on another
    mesh or scheme (mesh refinement), through the solution's collocation polynomials."""
    from .solution import OCPSolution

    if not isinstance(solution, OCPSolution):
        raise ModelError(f"warm_start must be a solution from problem.solve (an OCPSolution, or an "
                         f"OCPSolveError's .solution), got {type(solution).__name__}")
    pr, other = tr.problem, solution.transcription.problem
    for what, ours, theirs in (("coordinates", pr.model.coordinate_names, other.model.coordinate_names),
                               ("inputs", list(pr.model.inputs), list(other.model.inputs)),
                               ("constraints", tr.eqs.constraint_names, solution.trajectory.eqs.constraint_names)):
        if list(ours) != list(theirs):
            raise ModelError(f"warm_start: the solution's model '{other.model.name}' has {what} {list(theirs)}, "
                             f"this problem's model '{pr.model.name}' has {list(ours)}; pass a solution of the same model")
    t = tr.fractions * solution.t_final
    names = pr.model.coordinate_names + pr.model.speed_names
    X = np.array([solution.polynomial(n, t) for n in names])
    L = np.array([solution.polynomial(f"{c}.lambda", t) for c in tr.eqs.constraint_names]).reshape(tr.layout.nc, len(t))
    W = np.array([solution.polynomial(n, t) for n in pr.model.inputs]).reshape(tr.layout.n_in, len(t))
    return X, L, W
