"""Knee contact loads over the gait cycle with Hill muscles with compliant tendons (issue 15, candidate C20).

The default method (:mod:`.knee_collocation`: direct collocation with activation dynamics, backward Euler on the
frames, the same balances, reserves and objective) with every muscle a Hill-type muscle with a compliant tendon in
the implicit form of De Groote, Kinney, Rao, Fregly 2016 (Ann Biomed Eng 44:2922-2936,
doi:10.1007/s10439-016-1591-9; OpenSim Moco's ``DeGrooteFregly2016Muscle`` with implicit tendon compliance
dynamics); curves and geometry in :mod:`.knee_tendon_curves`. Per frame ``k`` and muscle ``m``:

- states: activation ``a`` and normalized tendon force ``F~T`` (``0 <= F~T <= 5``); controls: excitation ``e`` and
  ``dF~T/dt`` (the unknown is ``dF~T/dt / 10``, of order one);
- activation dynamics: the default's (:func:`.knee_collocation.activation_rate`), backward Euler;
- tendon force dynamics, the same transcription: ``F~T_k - F~T_(k-1) = h_k dF~T/dt_k`` (``k = 0``: the first
  interval's slope);
- equilibrium, a path constraint: ``F~T = (a f_L f_V + f_PE) cos(alpha)`` with the fibre's length and velocity from
  ``F~T``, ``dF~T/dt`` and the unit's length and rate;
- the balances (paper eqs. 35-41, as :mod:`.knee_static`) with the tendon's tension ``F0 F~T`` along each path:

      Q_c - M_c = sum_m r_mc F0_m (F~T_m - [c in passive rows] f_PE,m cos(alpha_m)) + sum_j lambda_j A_jc + rho_c,

  where ``M_c`` is Riener & Edrich's passive moment of all passive structures (C7) on the hip-flexion, knee-flexion
  and ankle rows (``passive_rows``): the fibres' passive force is part of it and is counted once, as
  ``--muscle-model hill`` does (:func:`.knee_passive.less_fibre_passive`), here as a function of the state;
- objective: the default's, ``sum_k w_k [sum_m (e^2 + a^2)/2 + W sum_c rho_c^2]`` (``dF~T/dt`` is not in it).

IPOPT starts from the rigid-tendon Hill static optimisation (:mod:`.knee_hill`, :func:`.knee_static.solve_static`):
``e = a`` its activations, ``F~T`` in equilibrium with them at zero tendon velocity.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import KneeError
from ..ocp.solver_threads import ipopt_solver
from ..output.signals import call_interruptibly
from .knee_collocation import TAU_ACT, TAU_DEACT, CollocationResult, activation_rate, ode_defects
from .knee_hill import hill_forces
from .knee_static import KKT_OPTIONS, LOAD_SCALE, RESERVE_WEIGHT, RESERVED, reserve_weight_rows, solve_static
from .knee_tendon_curves import (TENDON_STRAIN, active_force_length, equilibrium_residual, fibre_state,
                                 force_velocity, passive_force_length, static_tendon_force)

RATE_SCALE = 10.0      # 1/s: the NLP's tendon-force-rate unknown is dF~T/dt / RATE_SCALE
FT_MAX = 5.0           # upper bound of F~T (Moco's bound of the normalized tendon force)


@dataclass
class TendonResult(CollocationResult):
    """:class:`CollocationResult` plus the tendons: ``tendon_force`` (``F~T``, frames x muscles), its rate (1/s),
    the fibres' normalized length and velocity, and the largest equilibrium residual and tendon-force defect."""

    tendon_force: np.ndarray = None
    tendon_rate: np.ndarray = None
    fibre_length: np.ndarray = None
    fibre_velocity: np.ndarray = None
    equilibrium_residual: float = float("nan")
    tendon_defect: float = float("nan")


def _tiled(x, N: int) -> np.ndarray:
    return np.tile(np.asarray(x, float).reshape(-1, 1), (1, N))


def _block_diag(blocks: np.ndarray) -> ca.DM:
    """Sparse ``diag(blocks[0], blocks[1], ...)`` (frames x rows x cols), structural zeros dropped."""
    N, nr, nc = blocks.shape
    n, i, j = np.nonzero(blocks)
    return ca.DM.triplet((n * nr + i).tolist(), (n * nc + j).tolist(), ca.DM(blocks[n, i, j]), N * nr, N * nc)


def tendon_defects(t, FT, rate) -> np.ndarray:
    """Backward-Euler defects of ``dF~T/dt`` (frames x muscles, normalized force), NumPy."""
    h = np.diff(np.asarray(t, float))
    d = np.empty_like(FT)
    d[1:] = FT[1:] - FT[:-1] - h[:, None] * rate[1:]
    d[0] = FT[1] - FT[0] - h[0] * rate[0]
    return d


def solve_tendon(t, Qc, R, A, F0, L_mt, V_mt, l_opt, l_slack, alpha0, passive_rows=(), muscles_on: bool = True,
                 contact_nonnegative: bool = True, reserve_weight=RESERVE_WEIGHT, tau_act: float = TAU_ACT,
                 tau_deact: float = TAU_DEACT, strain: float = TENDON_STRAIN, tol: float = 1e-8,
                 max_iter: int = 1000, print_level: int = 0) -> TendonResult:
    """Whole cycle in one NLP (IPOPT), see the module docstring.

    ``t`` (s, frames); ``Qc`` (frames x rows, N m / N) the balances' right-hand sides *less* Riener & Edrich's
    passive moments on ``passive_rows`` (row indices); ``R`` (frames x rows x muscles, m) and ``A`` (frames x 5 x
    rows) as :func:`.knee_static.frame_data`; ``F0`` (N), ``l_opt``, ``l_slack`` (m), ``alpha0`` (rad) per muscle;
    ``L_mt`` (m) and ``V_mt`` (m/s), frames x muscles, the units' lengths and rates
    (:func:`.knee_static.muscle_kinematics`); ``strain``: the tendon strain at ``F0``.
    """
    clock = time.perf_counter()
    t = np.asarray(t, float)
    N, nr, nm = R.shape
    if N < 2 or np.any(np.diff(t) <= 0):
        raise KneeError("the compliant-tendon collocation needs at least two frames at increasing times")
    F0, l_opt, l_slack, alpha0 = (np.asarray(x, float).ravel() for x in (F0, l_opt, l_slack, alpha0))
    for name, x in (("F0", F0), ("l_opt", l_opt), ("l_slack", l_slack), ("alpha0", alpha0)):
        if x.shape != (nm,) or not np.all(np.isfinite(x)):
            raise KneeError(f"compliant tendon: '{name}' needs one finite value per muscle ({nm}), got {x.shape}")
    if np.any(l_opt <= 0) or np.any(l_slack <= 0):
        raise KneeError("compliant tendon: every optimal fibre length and tendon slack length must be > 0 m; "
                        "check the model file's muscles")
    nres = len(RESERVED)
    h = np.diff(t)
    hk = np.concatenate([[h[0]], h])
    w = np.zeros(N)
    w[:-1] += 0.5 * h
    w[1:] += 0.5 * h
    # x_k = [a, e, F~T, dF~T/dt / RATE_SCALE, lambda / LOAD_SCALE, rho]; balance rows divided by LOAD_SCALE
    ia, ie, iF, iu, il, ir = 0, nm, 2 * nm, 3 * nm, 4 * nm, 4 * nm + 5
    nx = ir + nres
    blocks = np.zeros((N, nr, nx))
    blocks[:, :, iF:iu] = R * F0[None, None, :]
    blocks[:, :, il:ir] = A.transpose(0, 2, 1) * LOAD_SCALE
    blocks[:, :nres, ir:] = np.eye(nres)
    B = _block_diag(blocks / LOAD_SCALE)
    X = ca.MX.sym("X", nx * N)
    Xm = ca.reshape(X, nx, N)
    a, e, FT, u = Xm[ia:ie, :], Xm[ie:iF, :], Xm[iF:iu, :], Xm[iu:il, :]
    Lm, Vm = ca.DM(np.asarray(L_mt, float).T), ca.DM(np.asarray(V_mt, float).T)
    lo, ls, al = (ca.DM(_tiled(x, N)) for x in (l_opt, l_slack, alpha0))
    l, v, cos_a = fibre_state(FT, RATE_SCALE * u, Lm, Vm, lo, ls, al, strain)
    fp = passive_force_length(l) * cos_a
    equilibrium = FT - (a * active_force_length(l) * force_velocity(v)) * cos_a - fp
    # the fibres' passive share of Riener & Edrich's moments, subtracted where those moments were (counted once)
    rows = []
    for c in range(nr):
        if c in passive_rows:
            rows.append(ca.sum1(ca.DM((R[:, c, :] * F0[None, :]).T / LOAD_SCALE) * fp))
        else:
            rows.append(ca.DM.zeros(1, N))
    passive_share = ca.vec(ca.vertcat(*rows))
    H = ca.DM(np.tile(hk, (nm, 1)))
    dA, dF = a[:, 1:] - a[:, :-1], FT[:, 1:] - FT[:, :-1]
    act_defect = ca.horzcat(dA[:, 0], dA) - H * activation_rate(e, a, tau_act, tau_deact, 0.0)
    ten_defect = ca.horzcat(dF[:, 0], dF) - H * RATE_SCALE * u
    weights = np.zeros((nx, N))
    weights[:iF], weights[ir:] = 0.5 * w, reserve_weight_rows(reserve_weight, N) * w
    rhs = (np.asarray(Qc, float) / LOAD_SCALE).ravel()
    nlp = {"x": X, "f": ca.dot(ca.DM(weights.ravel(order="F")), X * X),
           "g": ca.vertcat(ca.mtimes(B, X) - passive_share - ca.DM(rhs), ca.vec(act_defect), ca.vec(ten_defect),
                           ca.vec(equilibrium))}
    solver = ipopt_solver("knee_tendon", nlp, {
        "ipopt.print_level": print_level, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": tol,
        "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": max_iter, **KKT_OPTIONS})
    built = time.perf_counter()
    lbx, ubx = np.full((nx, N), -np.inf), np.full((nx, N), np.inf)
    lbx[:iF], ubx[:iF] = 0.0, (1.0 if muscles_on else 0.0)
    lbx[iF:iu], ubx[iF:iu] = 0.0, FT_MAX
    if contact_nonnegative:
        lbx[il:il + 2] = 0.0
    x0 = _start(t, Qc, R, A, F0, L_mt, V_mt, l_opt, l_slack, alpha0, passive_rows, muscles_on, contact_nonnegative,
                reserve_weight, strain, nx)
    sol = call_interruptibly(solver, x0=x0.ravel(order="F"), lbx=lbx.ravel(order="F"), ubx=ubx.ravel(order="F"),
                             lbg=0, ubg=0)
    stats = solver.stats()
    status = stats["return_status"]
    done = time.perf_counter()
    Xs = np.asarray(sol["x"]).reshape(nx, N, order="F")
    act, exc, ft, rate = Xs[ia:ie].T, Xs[ie:iF].T, Xs[iF:iu].T, RATE_SCALE * Xs[iu:il].T
    lam, rho = Xs[il:ir].T * LOAD_SCALE, Xs[ir:].T
    args = (np.asarray(L_mt, float), np.asarray(V_mt, float), l_opt, l_slack, alpha0)
    lf, vf, cf = fibre_state(ft, rate, *args, strain)
    fpass = passive_force_length(lf) * cf * F0
    force = ft * F0
    bal = np.einsum("ncm,nm->nc", R, force) + np.einsum("njc,nj->nc", A, lam) - np.asarray(Qc, float)
    bal[:, :nres] += rho
    for c in passive_rows:
        bal[:, c] -= np.einsum("nm,nm->n", R[:, c, :], fpass)
    residual = float(np.abs(bal).max())
    eq = float(np.abs(equilibrium_residual(act, ft, rate, *args, strain)).max())
    if not stats["success"]:
        raise KneeError(f"compliant-tendon collocation failed: IPOPT status '{status}' after "
                        f"{stats.get('iter_count', '?')} iterations, max balance residual {residual:.3g} N m, max "
                        f"equilibrium residual {eq:.3g} F0")
    return TendonResult(t, [], act, force, lam, rho, residual, status, {"build": built - clock, "solve": done - built},
                        excitation=exc, ode_residual=float(np.abs(ode_defects(t, act, exc, tau_act, tau_deact, 0.0)).max()),
                        tau=(tau_act, tau_deact), success=True, iterations=int(stats.get("iter_count", -1)),
                        tendon_force=ft, tendon_rate=rate, fibre_length=lf, fibre_velocity=vf, equilibrium_residual=eq,
                        tendon_defect=float(np.abs(tendon_defects(t, ft, rate)).max()))


def _start(t, Qc, R, A, F0, L_mt, V_mt, l_opt, l_slack, alpha0, passive_rows, muscles_on, contact_nonnegative,
           reserve_weight, strain, nx) -> np.ndarray:
    """IPOPT's start: the rigid-tendon Hill static optimisation (its limit of instant activation and stiff tendons),
    with ``F~T`` in equilibrium with its activations at zero tendon velocity."""
    N, nr, nm = R.shape
    hill = hill_forces(L_mt, V_mt, F0, l_opt, l_slack, alpha0)
    Qr = np.array(Qc, float, copy=True)
    for c in passive_rows:       # the rigid fibres' passive share, counted once as in the NLP
        Qr[:, c] += np.einsum("nm,nm->n", R[:, c, :], hill.passive)
    st = solve_static(t, Qr, R, A, hill.active, muscles_on=muscles_on, contact_nonnegative=contact_nonnegative,
                      reserve_weight=reserve_weight, passive=hill.passive)
    ft = static_tendon_force(st.activation, L_mt, V_mt, l_opt[None, :], l_slack[None, :], alpha0[None, :], strain,
                             upper=FT_MAX)
    x0 = np.zeros((nx, N))
    x0[:nm] = x0[nm:2 * nm] = st.activation.T
    x0[2 * nm:3 * nm] = ft.T
    x0[3 * nm:4 * nm, 1:] = (np.diff(ft, axis=0) / np.diff(t)[:, None]).T / RATE_SCALE
    x0[3 * nm:4 * nm, 0] = x0[3 * nm:4 * nm, 1]
    x0[4 * nm:4 * nm + 5], x0[4 * nm + 5:] = st.lam.T / LOAD_SCALE, st.reserve.T
    return x0


__all__ = ["FT_MAX", "RATE_SCALE", "TendonResult", "solve_tendon", "tendon_defects"]
