"""Junction times of arm_sat (or rod_lower) from the necessary conditions (indirect multiple shooting), independent of any
collocation: states x and costates lam with H = |u|^2 + lam . f(x, u); on a free phase u = argmin H =
-B(x)^T lam / 2, on an arc tau1 = +-bound and tau2 = -(B^T lam)_2 / 2 (u[0] = bound, the rest free); each junction is where the unconstrained
tau1 = -(B^T lam)_1 / 2 equals the bound (the switching condition, transversal here: |dtau1/dt| ~ 10 /s), x and lam
continuous. Unknowns lam(0), the 5 phase durations and the multiple-shooting nodes; CVODES at rtol = atol = TOL;
plain Newton. Guess: ref_arm_sat.pkl (costates from its inputs: lam_v = -2 B_v^-T u, lam_q = -lam_v' - a_v^T lam_v).

    python indirect.py [--M 8] [--tol 1e-13] [--ref arm_sat]    # prints the junction times and J
"""
from __future__ import annotations

import argparse
import pickle
import sys
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import reference as R  # noqa: E402


def build(name, phases, M, tol):
    if name == "cart_force":
        raise NotImplementedError("the bounded quantity must be the first input (arm_sat, rod_lower)")
    S = R.system(name)
    n2 = 2 * S["n"]
    x = ca.SX.sym("x", n2); lam = ca.SX.sym("lam", n2); u = ca.SX.sym("u", S["nu"])
    fx = S["f"](x, u)
    H = ca.sumsqr(u) + ca.dot(lam, fx)
    B = ca.jacobian(fx, u)                          # f is affine in u: B = B(x)
    ufree = -0.5 * B.T @ lam
    rhs = ca.vertcat(fx, -ca.jacobian(H, x).T)
    z = ca.vertcat(x, lam)
    dur = ca.SX.sym("dur")
    Fs, ufun, daes = {}, {}, {}
    for ii, (kind, val) in enumerate(sorted(set(phases))):
        uu = ufree if kind == "free" else ca.vertcat(val, *[ufree[i] for i in range(1, S["nu"])])
        ode = dur / M * ca.substitute(rhs, u, uu)
        daes[(kind, val)] = {"x": z, "p": dur, "ode": ode}
        Fs[(kind, val)] = ca.integrator(f"I{ii}", "cvodes", daes[(kind, val)], 0.0, 1.0,
                                        {"abstol": tol, "reltol": tol, "max_num_steps": 200000})
        ufun[(kind, val)] = ca.Function("u", [z], [uu])
    sw = ca.Function("sw", [z], [ufree[0]])          # the unconstrained tau1
    cost = ca.Function("c", [z, u], [ca.sumsqr(u)])
    return S, Fs, ufun, sw, n2, daes


def solve(ref, M=8, tol=1e-13, verbose=True):
    phases = [tuple(p) for p in ref["phases"]]
    S, Fs, ufun, sw, n2, daes = build(ref["name"], phases, M, tol)
    P = len(phases)
    # unknowns
    lam0 = ca.MX.sym("lam0", n2)
    nodes = [[ca.MX.sym(f"z{p}_{m}", 2 * n2) if (p, m) != (0, 0) else None for m in range(M)] for p in range(P)]
    durs = ca.MX.sym("durs", P)
    W = ca.vertcat(lam0, *[nodes[p][m] for p in range(P) for m in range(M) if (p, m) != (0, 0)], durs)
    res = []
    zcur = ca.vertcat(ca.DM(S["x0"]), lam0)
    for p in range(P):
        for m in range(M):
            zs = zcur if (p, m) == (0, 0) else nodes[p][m]
            ze = Fs[phases[p]](x0=zs, p=durs[p])["xf"]
            last = (p == P - 1 and m == M - 1)
            if last:
                res.append(ze[:n2] - ca.DM(S["xf"]))
            else:
                nxt = nodes[p][m + 1] if m + 1 < M else nodes[p + 1][0]
                res.append(ze - nxt)
            if m == M - 1 and p < P - 1:          # junction p / p+1: the switching condition
                val = phases[p + 1][1] if phases[p][0] == "free" else phases[p][1]
                res.append(sw(ze) - val)
    res.append(ca.sum1(durs) - S["T"])
    res = ca.vertcat(*res)
    G = ca.Function("G", [W], [res])
    JG = ca.Function("JG", [W], [ca.jacobian(res, W)])
    # guess from the collocation reference
    w0 = _guess(ref, S, Fs, phases, M, n2, daes)
    w = w0.copy()
    for it in range(40):
        r = np.array(G(w)).ravel()
        nr = np.abs(r).max()
        if verbose:
            print(f"newton {it}: |res| {nr:.3e}", flush=True)
        if nr < 1e-12:
            break
        dw = np.linalg.solve(np.array(JG(w)), -r)
        a = 1.0
        while a > 1e-4:
            if np.abs(np.array(G(w + a * dw)).ravel()).max() < (1 - 0.25 * a) * nr or nr < 1e-9:
                break
            a /= 2
        w = w + a * dw
    dv = w[-P:]
    junctions = list(np.cumsum(dv)[:-1])
    # the objective along the solution (dense integration of |u|^2 with the same integrator, per segment)
    lam0v = w[:n2]
    J = _objective(S, phases, ufun, daes, w, dv, M, n2, tol)
    return dict(junctions=junctions, durations=dv, lam0=lam0v, residual=nr, newton_iters=it, objective=J, M=M,
                tol=tol, w=w)


def _objective(S, phases, ufun, daes, w, dv, M, n2, tol):
    """J = int |u|^2 dt, by Gauss-Legendre (20 points) on each segment from a dense CVODES output."""
    from numpy.polynomial.legendre import leggauss
    xg, wg = leggauss(20)
    s = (xg + 1) / 2
    J = 0.0
    k = n2
    z = np.concatenate([S["x0"], w[:n2]])
    for p in range(len(phases)):
        I = ca.integrator("Id", "cvodes", daes[phases[p]], 0.0, list(s),
                          {"abstol": tol, "reltol": tol, "max_num_steps": 200000})
        for m in range(M):
            if (p, m) != (0, 0):
                z = w[k:k + 2 * n2]; k += 2 * n2
            Z = np.array(I(x0=z, p=dv[p])["xf"])
            uu = np.array([np.array(ufun[phases[p]](Z[:, i])).ravel() for i in range(len(s))])
            J += dv[p] / M * 0.5 * np.sum(wg * np.sum(uu**2, axis=1))
    return float(J)


def _guess(ref, S, Fs, phases, M, n2, daes):
    """Nodes from the collocation reference: x interpolated; lam from its inputs on free phases, integrated
    across arcs from the preceding node (backwards from the following free phase for an arc at t = 0)."""
    nq = S["n"]
    x = ca.SX.sym("x", n2); u = ca.SX.sym("u", S["nu"])
    fx = S["f"](x, u)
    Bv = ca.jacobian(fx, u)[nq:, :]
    av = ca.jacobian(fx[nq:], x[nq:])
    fB = ca.Function("fB", [x], [Bv]); fav = ca.Function("fav", [x, u], [av])
    d = ref["durations"]; t0s = np.concatenate([[0], np.cumsum(d)])

    def lam_at(t):
        def lv(tt):
            return -2 * np.linalg.solve(np.array(fB(R._xfun(ref, tt))).T, R._ufun(ref, tt))
        e = 1e-6
        lvd = (lv(t + e) - lv(t - e)) / (2 * e)
        lvv = lv(t)
        lq = -lvd - np.array(fav(R._xfun(ref, t), R._ufun(ref, t))).T @ lvv
        return np.concatenate([lq, lvv])

    parts = []
    z_prev_end = None
    for p in range(len(phases)):
        for m in range(M):
            t = t0s[p] + m * d[p] / M
            tt = min(max(t, 1e-5), t0s[-1] - 1e-5)
            if phases[p][0] == "free":
                zz = np.concatenate([R._xfun(ref, tt + (1e-5 if m == 0 else 0)), lam_at(tt + (2e-5 if m == 0 else 0))])
            elif z_prev_end is None:            # an arc first: integrate back from the next free phase
                if m == 0:
                    dae = dict(daes[phases[p]]); dae["ode"] = -dae["ode"]
                    Fb = ca.integrator("Ib", "cvodes", dae, 0.0, 1.0, {"abstol": 1e-12, "reltol": 1e-12})
                    tj = t0s[p + 1] + 2e-5
                    zb = [np.concatenate([R._xfun(ref, tj), lam_at(tj)])]
                    for _ in range(M):
                        zb.append(np.array(Fb(x0=zb[-1], p=d[p])["xf"]).ravel())
                    back = zb[::-1]
                zz = back[m]
            else:
                zz = z_prev_end
            if (p, m) == (0, 0):
                parts.append(zz[n2:])
            else:
                parts.append(zz)
            z_prev_end = np.array(Fs[phases[p]](x0=zz, p=d[p])["xf"]).ravel()
    parts.append(d)
    return np.concatenate(parts)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--M", type=int, default=8); ap.add_argument("--tol", type=float, default=1e-13)
    ap.add_argument("--ref", default="arm_sat")
    a = ap.parse_args()
    ref = pickle.load(open(HERE / f"ref_{a.ref}.pkl", "rb"))
    out = solve(ref, a.M, a.tol)
    print("indirect M", a.M, "tol", a.tol, "residual", out["residual"], "newton", out["newton_iters"])
    print("durations", list(map(float, out["durations"])))
    print("junctions", list(map(float, out["junctions"])))
    print("J", out["objective"])
    print("lam0", list(map(float, out["lam0"])))


if __name__ == "__main__":
    main()
