"""Solvers of the minimal-coordinate problems (:mod:`.ocp_suite_minimal`): rockit, and a plain
CasADi collocation that gives the reference objectives.

- :func:`solve_rockit`: rockit's ``DirectCollocation(N, degree, scheme="radau")`` (piecewise-constant
  controls, path constraints on its control grid), IPOPT through rockit's Opti stack.
- :func:`collocate`: Legendre-Gauss-Radau collocation of degree ``d`` written here in a few lines
  (states at every point, controls at the collocation points, path constraints at every
  collocation point, Radau quadrature of the integrand), IPOPT with exact Hessians. On a fine
  mesh its optimum is the reference objective of the suite: a different formulation (minimal
  coordinates) and a different transcription from the library's.

Both start from the same guess as the library's side: states linear between the boundary
values, controls zero.
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np

from ..ocp.solver_threads import ipopt_solver
from .ocp_suite_minimal import Minimal

IPOPT = {"ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 3000, "ipopt.print_level": 0,
         "print_time": False, "record_time": True, "ipopt.sb": "yes"}


def _result(success, status, iterations, objective, solve_s, ipopt_s, setting) -> dict:
    return {"success": bool(success), "status": str(status), "iterations": int(iterations), "objective": float(objective),
            "solve_s": float(solve_s), "ipopt_s": float(ipopt_s), "setting": setting}


def solve_rockit(mp: Minimal, N: int, degree: int = 3, expand: bool = True) -> dict:
    """rockit on the minimal-coordinate problem; ``solve_s`` is the wall time from an empty
    ``rockit.Ocp`` to the solution (problem construction, transcription, solver setup, IPOPT)."""
    import rockit

    started = time.perf_counter()
    ocp = rockit.Ocp(T=mp.T)
    x, z, u = ocp.state(mp.x.numel()), ocp.algebraic(mp.z.numel()), ocp.control(mp.u.numel())
    f = ca.Function("f", [mp.x, mp.z, mp.u], [mp.xdot, mp.alg, mp.cost] + [g for g, _, _ in mp.path])
    out = f(x, z, u)
    ocp.set_der(x, out[0])
    ocp.add_alg(out[1])
    ocp.add_objective(ocp.integral(out[2]))
    for i, (lo, hi) in enumerate(mp.u_bounds):
        _bound(ocp, u[i], lo, hi)
    for i, (lo, hi) in mp.x_bounds.items():
        _bound(ocp, x[i], lo, hi)
    for g, (_, lo, hi) in zip(out[3:], mp.path):
        _bound(ocp, g, lo, hi)
    for i, (a, b) in enumerate(zip(mp.x0, mp.xf)):
        if a is not None:
            ocp.subject_to(ocp.at_t0(x[i]) == a)
        if b is not None:
            ocp.subject_to(ocp.at_tf(x[i]) == b)
    a, b = mp.guess(np.array([0.0, 1.0])).T
    ocp.set_initial(x, ca.vertcat(*[mp.guesses[i](ocp.t) if i in mp.guesses else a[i] + (b[i] - a[i]) * ocp.t / mp.T
                                    for i in range(len(a))]))
    ocp.solver("ipopt", {**IPOPT, "expand": expand})
    ocp.method(rockit.DirectCollocation(N=N, degree=degree, scheme="radau"))
    try:
        sol = ocp.solve()
        stats, objective = sol.stats, float(sol.value(ocp.objective))
    except RuntimeError:                              # rockit raises when IPOPT fails
        sol = ocp.non_converged_solution
        stats, objective = sol.stats, float(sol.value(ocp.objective))
    solve_s = time.perf_counter() - started
    return _result(stats.get("success", False), stats.get("return_status"), stats.get("iter_count", -1), objective,
                   solve_s, _ipopt_seconds(stats),
                   f"rockit DirectCollocation(N={N}, degree={degree}, radau)")


def _bound(ocp, expr, lo, hi) -> None:
    if np.isfinite(lo) and np.isfinite(hi):
        ocp.subject_to(lo <= (expr <= hi))
    elif np.isfinite(hi):
        ocp.subject_to(expr <= hi)
    elif np.isfinite(lo):
        ocp.subject_to(expr >= lo)


def collocate(mp: Minimal, N: int, degree: int, ipopt: dict | None = None, start=None) -> dict:
    """Radau collocation of degree ``degree`` on ``N`` equal intervals (see the module docstring).

    ``start``: a function of times (s) giving states and controls there, ``(X, U)``, to start from
    instead of the linear guess (to find the local optimum nearest to another solution).

    Each interval is one SX function of its own variables (its start, states, algebraic variables
    and controls at its collocation points); IPOPT gets the NLP's exact Jacobian and Hessian
    gathered from that function's, mapped over the intervals (:func:`_gathered`)."""
    started = time.perf_counter()
    nx, nz, nu, d = mp.x.numel(), mp.z.numel(), mp.u.numel(), degree
    tau = ca.collocation_points(d, "radau")
    C, _, B = (np.asarray(m) for m in ca.collocation_coeff(tau))
    h = mp.T / N
    g = ca.vertcat(*[e for e, _, _ in mp.path]) if mp.path else ca.SX(0, 1)
    f = ca.Function("f", [mp.x, mp.z, mp.u], [mp.xdot, mp.alg, mp.cost, g])
    x0, Xc, Zc, Uc = ca.SX.sym("x0", nx), ca.SX.sym("X", nx, d), ca.SX.sym("Z", nz, d), ca.SX.sym("U", nu, d)
    fx, fa, fc, fg = f.map(d)(Xc, Zc, Uc)
    v = ca.vertcat(x0, ca.vec(Xc), ca.vec(Zc), ca.vec(Uc))
    rows = ca.vertcat(ca.vec(ca.horzcat(x0, Xc) @ C - h * fx), ca.vec(fa), ca.vec(fg))
    interval = ca.Function("interval", [v], [rows, h * fc @ B])
    # Decision vector: x(0), then per interval its states, algebraic variables and controls.
    per = (nx + nz + nu) * d
    base = nx + per * np.arange(N)[:, None]
    own = base + np.arange(per)[None, :]
    last = base + (d - 1) * nx + np.arange(nx)[None, :]                # the interval's last state
    starts = np.vstack([np.arange(nx)[None, :], last[:-1]])
    idx = np.hstack([starts, own])
    n = nx + per * N
    lbx, ubx = np.full(n, -np.inf), np.full(n, np.inf)
    lo = np.concatenate([np.tile([mp.x_bounds.get(i, (-np.inf, np.inf))[0] for i in range(nx)], d), np.full(nz * d, -np.inf),
                         np.tile([b[0] for b in mp.u_bounds], d)])
    hi = np.concatenate([np.tile([mp.x_bounds.get(i, (-np.inf, np.inf))[1] for i in range(nx)], d), np.full(nz * d, np.inf),
                         np.tile([b[1] for b in mp.u_bounds], d)])
    lbx[own.ravel()], ubx[own.ravel()] = np.tile(lo, N), np.tile(hi, N)
    for i, (a, b) in enumerate(zip(mp.x0, mp.xf)):
        if a is not None:
            lbx[i] = ubx[i] = a
        if b is not None:
            lbx[last[-1, i]] = ubx[last[-1, i]] = b
    glo = np.concatenate([np.zeros((nx + nz) * d)] + [np.full(d, lo) for _, lo, _ in mp.path])
    ghi = np.concatenate([np.zeros((nx + nz) * d)] + [np.full(d, hi) for _, _, hi in mp.path])
    path_order = np.arange((nx + nz) * d + g.numel() * d)
    path_order[(nx + nz) * d:] = (nx + nz) * d + np.arange(g.numel() * d).reshape(d, -1).T.ravel()
    lbg, ubg = np.tile(glo[np.argsort(path_order)], N), np.tile(ghi[np.argsort(path_order)], N)
    nlp, derivatives = _gathered(interval, idx, n)
    solver = ipopt_solver("reference", nlp, {**IPOPT, **(ipopt or {}), **derivatives})
    times = np.concatenate([(k + np.asarray(tau)) / N for k in range(N)])
    guess = np.zeros(n)
    guess[:nx] = mp.guess(0.0)[:, 0]
    guess[(base + np.arange(nx * d)[None, :]).ravel()] = mp.guess(times).T.reshape(N, d * nx).ravel()
    Us = np.zeros((nu, N * d))
    if start is not None:
        Xs, Us = start(np.concatenate([[0.0], times]) * mp.T)
        guess[:nx] = Xs[:, 0]
        guess[(base + np.arange(nx * d)[None, :]).ravel()] = Xs[:, 1:].T.ravel()
        Us = Us[:, 1:]
        guess[(base + (nx + nz) * d + np.arange(nu * d)[None, :]).ravel()] = Us.T.ravel()
    # The algebraic variables that fit: alg is affine in z, so z = -(d alg/dz)^-1 alg(x, 0, u).
    Xg = guess[(base + np.arange(nx * d)[None, :]).ravel()].reshape(N * d, nx).T
    zero = ca.DM.zeros(nz)
    solve_z = ca.Function("z", [mp.x, mp.u], [-ca.solve(ca.jacobian(mp.alg, mp.z), ca.substitute(mp.alg, mp.z, zero))])
    Zg = np.asarray(solve_z.map(N * d)(Xg, Us))
    guess[(base + nx * d + np.arange(nz * d)[None, :]).ravel()] = Zg.T.ravel()
    res = solver(x0=guess, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    out = _result(stats["success"], stats["return_status"], stats["iter_count"], float(res["f"]),
                  time.perf_counter() - started, _ipopt_seconds(stats), f"minimal-coordinate Radau{d} N={N}")
    xs = np.asarray(res["x"]).ravel()
    out["t"] = np.concatenate([[0.0], times * mp.T])
    out["x"] = np.column_stack([xs[:nx], xs[(base + np.arange(nx * d)[None, :]).ravel()].reshape(N * d, nx).T])
    out["z"] = xs[(base + nx * d + np.arange(nz * d)[None, :]).ravel()].reshape(N * d, nz).T
    out["u"] = xs[(base + (nx + nz) * d + np.arange(nu * d)[None, :]).ravel()].reshape(N * d, nu).T
    return out


def _gathered(F: ca.Function, idx: np.ndarray, n: int) -> tuple[dict, dict]:
    """The NLP ``g = (rows of F(w[idx[k]]))_k``, ``f = sum_k cost_k`` and its exact derivatives,
    each taken once on ``F`` and mapped over the ``K`` instances, then summed into place."""
    K, m = idx.shape
    nr = F.size1_out(0)
    w, lam_f, lam_g = ca.MX.sym("w", n), ca.MX.sym("lam_f"), ca.MX.sym("lam_g", nr * K)
    p = ca.MX.sym("p", 0)
    V = ca.reshape(w[idx.ravel().tolist()], m, K)
    Lam = ca.reshape(lam_g, nr, K)
    v, lam, lf = ca.SX.sym("v", m), ca.SX.sym("lam", nr), ca.SX.sym("lf")
    rows, cost = F(v)
    J, grad = ca.jacobian(rows, v), ca.gradient(cost, v)
    H = ca.tril(ca.hessian(lf * cost + ca.dot(lam, rows), v)[0])
    k = np.arange(K)[:, None]

    def values(name, expr, args, inputs):
        return ca.vec(ca.Function(name, args, [expr.nz[:]]).map(K)(*inputs))

    jr, jc = (np.asarray(a) for a in J.sparsity().get_triplet())
    hr, hc = (np.asarray(a) for a in H.sparsity().get_triplet())
    jac = _matrix(values("interval_jac", J, [v], [V]), k * nr + jr[None, :], idx[:, jc], nr * K, n)
    grad_f = _matrix(values("interval_grad", ca.densify(grad), [v], [V]), idx, 0 * idx, n, 1)
    hess = _matrix(values("interval_hess", H, [v, lam, lf], [V, Lam, lam_f]), np.minimum(idx[:, hr], idx[:, hc]),
                   np.maximum(idx[:, hr], idx[:, hc]), n, n)
    g_all, costs = F.map(K)(V)
    f = ca.sum2(costs)
    nlp = {"x": w, "f": f, "g": ca.vec(g_all)}
    return nlp, {"grad_f": ca.Function("grad_f", [w, p], [f, ca.densify(grad_f)], ["x", "p"], ["f", "grad_f_x"]),
                 "jac_g": ca.Function("jac_g", [w, p], [ca.vec(g_all), jac], ["x", "p"], ["g", "jac_g_x"]),
                 "hess_lag": ca.Function("hess_lag", [w, p, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"],
                                         ["triu_hess_gamma_x_x"])}


def _matrix(source: ca.MX, rows: np.ndarray, cols: np.ndarray, nrow: int, ncol: int) -> ca.MX:
    """The sparse matrix with ``source[i]`` added at ``(rows[i], cols[i])`` (repeated positions add up)."""
    r, c = rows.ravel(), cols.ravel()
    unique, position = np.unique(c * nrow + r, return_inverse=True)
    sparsity = ca.Sparsity.triplet(nrow, ncol, (unique % nrow).tolist(), (unique // nrow).tolist())
    gather = ca.DM(ca.Sparsity.triplet(len(unique), len(r), position.tolist(), list(range(len(r)))), 1.0)
    return ca.MX(sparsity, ca.mtimes(gather, source))


def _ipopt_seconds(stats: dict) -> float:
    """Wall time inside IPOPT's solve call (its own iterations and the callbacks)."""
    return float(stats.get("t_wall_total", stats.get("t_wall_solver", float("nan"))))
