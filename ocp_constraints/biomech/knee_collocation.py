"""Minimum-effort knee contact loads over the whole gait cycle by direct collocation (issue 7, item (b)).

Same frames, same equations per frame as the static optimisation (:mod:`.knee_static`):
the kinematics are prescribed by the measured motion, so the problem is over the muscle
states only. Per frame ``k`` (time ``t_k``, the frames are the mesh) the unknowns are

- activations ``a_k`` (states, ``0 <= a <= 1``) and excitations ``e_k`` (controls, ``0 <= e <= 1``),
- the five knee multipliers ``lambda_k`` (``N_medial, N_lateral >= 0``, ``ap``, ``ml``, ``ie``),
- reserve torques ``rho_k`` (N m) on the primary coordinates,

with the leg's generalized-force balance of the static problem at every frame,

    Q_c = sum_m r_mc (F0_m a_m + Fp_m) + sum_j lambda_j A_jc + rho_c,

and first-order activation dynamics in the form ``da/dt = (e - a) / tau(e, a)``. The default
is the excitation-dependent time constant of Raasch, Zajac, Ma, Levine 1997 ("Muscle
coordination of maximum-speed pedaling", J Biomech 30:595-602), also used by De Groote et al.

    da/dt = (e - a) (e / tau_act + (1 - e) / tau_deact)       (smoothing = 0, default)

(``tau = tau_act`` at full excitation, ``tau_deact`` at none); the smooth switch of De Groote,
Kinney, Rao, Fregly 2016 ("Evaluation of direct collocation optimal control problem
formulations for solving the muscle redundancy problem", Ann Biomed Eng 44:2922-2936,
doi:10.1007/s10439-016-1591-9, eqs. 1-2) is available with ``smoothing = b > 0``:

    1/tau = (f + 1/2) / (tau_act (1/2 + 3a/2)) + (1/2 + 3a/2) (1/2 - f) / tau_deact,
    f = tanh(b (e - a)) / 2

(``b = 10`` is OpenSim Moco's ``DeGrooteFregly2016Muscle`` default; the paper prints 0.1).
Time constants ``tau_act = 15 ms``, ``tau_deact = 60 ms`` (De Groote et al. 2016). On the
JW gait cycle the tanh form did not converge within 1000 IPOPT iterations (its switch
makes the defects strongly nonconvex), the Raasch form converges from the static solution
(91 / 82 / 71 IPOPT iterations on ngait_og5 / bouncy7 / mtpgait3 with the string-fitted muscle paths of
0c7f208, 84 / 80 / 69 before them): hence the default.

Transcription: first-order Radau IIA collocation (backward Euler) on the frames' grid,
L-stable, so it stays well behaved when ``tau << h`` (the fast-activation limit below),
which trapezoidal collocation is not (its defects only fix ``(e-a)_k + (e-a)_{k+1}``
and allow an alternating excitation):

    a_k - a_{k-1} = h_k da/dt(e_k, a_k),   k = 1..N-1   (collocation points: the frames 1..N-1),

and at the first frame, which has no interval ending on it, the excitation is the one
that gives the first interval's slope: ``a_1 - a_0 = h_1 da/dt(e_0, a_0)``. The initial
activation is free (no periodicity is imposed: the measured cycle is not exactly periodic).

Objective, the time integral over the cycle (trapezoidal frame weights ``w_k``)

    J = sum_k w_k [ sum_m (e_km^2 + a_km^2) / 2 + W sum_c rho_kc^2 ],

so that in the limit ``tau -> 0`` (``e = a``) each frame's term is the static problem's
``sum a^2 + W sum rho^2`` times ``w_k``: the static optimisation is the fast-activation
limit of this problem (test). One NLP over all frames (IPOPT through ``casadi.nlpsol``, exact
Hessian): the balances, linear in the unknowns, as one sparse block-diagonal matrix, the defects
elementwise on the (muscles x frames) arrays.

Local optima. The Raasch rate is not monotonic in ``e`` when ``a > tau_act / (tau_deact - tau_act)
= 1/3``, so a muscle can deactivate with ``e = 0`` or with a small positive ``e``: the NLP has many
local optima that differ in a few frames' excitations (objective 1e-7..2e-2 relative apart, loads up
to 0.6 BW). Which one IPOPT reaches depends on its path: starting points, barrier settings and
objective scaling other than these moved it to another optimum on ngait_og5
(``scripts/knee_collocation_speed.py``, which also checks that a change leaves the solution as it was).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .knee_static import (KKT_OPTIONS, LOAD_SCALE, RESERVE_WEIGHT, RESERVED, StaticResult, _balance_residual,
                          _block_diagonal, reserve_weight_rows)
from ..errors import KneeError
from ..ocp.solver_threads import ipopt_solver
from ..output.signals import call_interruptibly

TAU_ACT = 0.015        # s, De Groote et al. 2016
TAU_DEACT = 0.060      # s, De Groote et al. 2016
SMOOTHING = 0.0        # 0: Raasch et al. 1997 form; b > 0: De Groote et al. 2016 tanh(b (e - a)) (Moco: b = 10)
# KKT_OPTIONS (imported from .knee_static): how MUMPS factorizes the KKT matrix, about 90 % of this solve (160
# factorizations on ngait_og5, about two per iteration: the nonconvex defects need inertia corrections).


def activation_rate(e, a, tau_act: float = TAU_ACT, tau_deact: float = TAU_DEACT, b: float = SMOOTHING):
    """``da/dt``; works on numbers, numpy arrays and CasADi symbols.

    ``b > 0``: De Groote et al. 2016 (eqs. 1-2), smoothing ``b``. ``b == 0``: the
    excitation-dependent time constant ``1/tau = e/tau_act + (1 - e)/tau_deact``
    (Raasch et al. 1997), ``da/dt = (e - a)(e/tau_act + (1 - e)/tau_deact)``.
    """
    if b == 0:
        return (e - a) * (e / tau_act + (1 - e) / tau_deact)
    th = ca.tanh if isinstance(e, (ca.SX, ca.MX, ca.DM)) or isinstance(a, (ca.SX, ca.MX, ca.DM)) else np.tanh
    f = 0.5 * th(b * (e - a))
    s = 0.5 + 1.5 * a
    return ((f + 0.5) / (tau_act * s) + s * (0.5 - f) / tau_deact) * (e - a)


@dataclass
class CollocationResult(StaticResult):
    """:class:`StaticResult` plus the excitations (frames x muscles) and the activation-dynamics data."""

    excitation: np.ndarray = None
    ode_residual: float = float("nan")
    tau: tuple[float, float] = (TAU_ACT, TAU_DEACT)
    iterations: int = -1


def solve_collocation_or_static(t, Qc, R, A, F0, muscles_on: bool = True, passive=None, **options) -> StaticResult:
    """:func:`solve_collocation`, or where IPOPT fails on it, the static optimisation with ``fallback`` saying why.

    The collocation's NLP is not convex (module notes) and was adopted as the default on three trials; on
    another trial IPOPT may fail where the static problem, a convex QP and the collocation's own starting
    point (its limit of instant activation), solves. A failed run keeps what it had: these static loads,
    reported as such (``fallback``; ``summary.json`` and the command line say so), never as the collocation's.
    """
    from .knee_static import solve_static

    try:
        return solve_collocation(t, Qc, R, A, F0, muscles_on=muscles_on, passive=passive, **options)
    except KneeError as exc:
        if not str(exc).startswith("collocation failed"):
            raise
        # The same problem's static limit: the options the two share (reserve weights, contact signs) go along.
        shared = {k: options[k] for k in ("reserve_weight", "contact_nonnegative") if k in options}
        res = solve_static(t, Qc, R, A, F0, muscles_on=muscles_on, passive=passive, **shared)
        res.fallback = (f"{exc}; the loads are the static optimisation's (activation dynamics left out: "
                        f"their limit of instant activation)")
        return res


def ode_defects(t, a, e, tau_act: float = TAU_ACT, tau_deact: float = TAU_DEACT, b: float = SMOOTHING) -> np.ndarray:
    """Defects of the collocation equations (frames x muscles, activation units), numpy."""
    t = np.asarray(t, float)
    h = np.diff(t)
    d = np.empty_like(a)
    d[1:] = a[1:] - a[:-1] - h[:, None] * activation_rate(e[1:], a[1:], tau_act, tau_deact, b)
    d[0] = a[1] - a[0] - h[0] * activation_rate(e[0], a[0], tau_act, tau_deact, b)
    return d


def solve_collocation(t, Qc, R, A, F0, muscles_on: bool = True, contact_nonnegative: bool = True,
                      reserve_weight: float = RESERVE_WEIGHT, passive=None, tau_act: float = TAU_ACT,
                      tau_deact: float = TAU_DEACT, smoothing: float = SMOOTHING, tol: float = 1e-8,
                      max_iter: int = 1000, warm_start: bool = True, print_level: int = 0,
                      ipopt_options: dict | None = None) -> CollocationResult:
    """Whole cycle in one NLP (IPOPT): see the module docstring. Arguments as :func:`.knee_static.solve_static`.

    ``warm_start``: start IPOPT from the static optimisation's solution (``e = a`` = its
    activations, its multipliers and reserves), the fast-activation limit; otherwise from
    ``a = e = 0.05``, zero multipliers and reserves.
    """
    clock = time.perf_counter()
    t = np.asarray(t, float)
    N, nr, nm = R.shape
    if N < 2 or np.any(np.diff(t) <= 0):
        raise KneeError("collocation needs at least two frames at increasing times")
    F0 = np.broadcast_to(np.asarray(F0, float), (N, nm))
    passive = np.zeros((N, nm)) if passive is None else np.asarray(passive, float)
    nres = len(RESERVED)
    h = np.diff(t)
    hk = np.concatenate([[h[0]], h])                     # interval length used by frame k's defect
    w = np.zeros(N)
    w[:-1] += 0.5 * h
    w[1:] += 0.5 * h                                     # trapezoidal weights of the time integral

    # frame k's unknowns x_k = [a, e, lambda / LOAD_SCALE, rho], frames in sequence. The balances are linear
    # in x: one constant sparse block per frame, rows divided by LOAD_SCALE as in the static problem, so the
    # unknowns and residuals IPOPT sees are of order one (84 instead of 126 iterations on ngait_og5, the same
    # optimum). The defects are elementwise on the (muscles x frames) arrays a and e: a handful of MX nodes,
    # built in 0.1 s, where a per-frame Function mapped over the frames and expanded took 4 s.
    nx = 2 * nm + 5 + nres
    blocks = np.zeros((N, nr, nx))
    blocks[:, :, :nm] = R * F0[:, None, :]
    blocks[:, :, 2 * nm:2 * nm + 5] = A.transpose(0, 2, 1) * LOAD_SCALE
    blocks[:, :nres, 2 * nm + 5:] = np.eye(nres)
    B = _block_diagonal(blocks / LOAD_SCALE)
    rhs = ((Qc - np.einsum("ncm,nm->nc", R, passive)) / LOAD_SCALE).ravel()
    X = ca.MX.sym("X", nx * N)
    Xm = ca.reshape(X, nx, N)
    a, e = Xm[:nm, :], Xm[nm:2 * nm, :]
    dA = a[:, 1:] - a[:, :-1]
    slope = ca.horzcat(dA[:, 0], dA)                     # a_k - a_{k-1}; a_1 - a_0 at k = 0
    defect = slope - ca.DM(np.tile(hk, (nm, 1))) * activation_rate(e, a, tau_act, tau_deact, smoothing)
    weights = np.zeros((nx, N))
    weights[:2 * nm], weights[2 * nm + 5:] = 0.5 * w, reserve_weight_rows(reserve_weight, N) * w
    nlp = {"x": X, "f": ca.dot(ca.DM(weights.ravel(order="F")), X * X),
           "g": ca.vertcat(ca.mtimes(B, X) - ca.DM(rhs), ca.vec(defect))}
    solver = ipopt_solver("knee_col", nlp, {"ipopt.print_level": print_level, "print_time": False, "ipopt.sb": "yes",
                                             "ipopt.tol": tol, "ipopt.constr_viol_tol": 1e-10,
                                             "ipopt.max_iter": max_iter, **KKT_OPTIONS,
                                             **(ipopt_options or {})})
    built = time.perf_counter()
    lbx, ubx = np.full((nx, N), -np.inf), np.full((nx, N), np.inf)
    lbx[:2 * nm], ubx[:2 * nm] = 0.0, (1.0 if muscles_on else 0.0)
    if contact_nonnegative:
        lbx[2 * nm:2 * nm + 2] = 0.0
    x0 = np.zeros((nx, N))
    x0[:2 * nm] = 0.05 if muscles_on else 0.0
    if warm_start and muscles_on:
        from .knee_static import solve_static

        st = solve_static(t, Qc, R, A, F0, muscles_on=muscles_on, contact_nonnegative=contact_nonnegative,
                          reserve_weight=reserve_weight, passive=passive)
        x0[:nm] = x0[nm:2 * nm] = st.activation.T
        x0[2 * nm:2 * nm + 5], x0[2 * nm + 5:] = st.lam.T / LOAD_SCALE, st.reserve.T
    sol = call_interruptibly(solver, x0=x0.ravel(order="F"), lbx=lbx.ravel(order="F"),
                             ubx=ubx.ravel(order="F"), lbg=0, ubg=0)   # Ctrl-C: RunInterrupted, not a failure
    stats = solver.stats()
    status = stats["return_status"]
    done = time.perf_counter()
    Xs = np.asarray(sol["x"]).reshape(nx, N, order="F")
    Xs[2 * nm:2 * nm + 5] *= LOAD_SCALE
    residual = _balance_residual(Qc, R, A, Xs[:nm].T * F0 + passive, Xs[2 * nm:2 * nm + 5].T, Xs[2 * nm + 5:].T)
    if not stats["success"]:
        raise KneeError(f"collocation failed: IPOPT status '{status}' after {stats.get('iter_count', '?')} "
                        f"iterations, max balance residual {residual:.3g} N m")
    act, exc = Xs[:nm].T, Xs[nm:2 * nm].T
    ode = float(np.abs(ode_defects(t, act, exc, tau_act, tau_deact, smoothing)).max())
    return CollocationResult(t, [], act, act * F0 + passive, Xs[2 * nm:2 * nm + 5].T, Xs[2 * nm + 5:].T,
                             residual, status, {"build": built - clock, "solve": done - built}, excitation=exc,
                             ode_residual=ode, tau=(tau_act, tau_deact), success=bool(stats["success"]),
                             iterations=int(stats.get("iter_count", -1)))
