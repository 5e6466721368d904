"""Independent references: plain CasADi, Lagrange's equations in minimal coordinates, multi-phase Radau IIA
collocation with FREE phase durations (free arc / arc with the bound imposed as an equality), IPOPT tol 1e-12.
Constraint forces by Newton-Euler on the reference motion. Nothing from ocp_constraints is used here except
(optionally) its fixed-mesh solution as the initial guess and to read the arc structure (--guess-from-lib).

    python reference.py NAME [--N 40] [--degree 7]     # solves N and 2N, writes ref_NAME.pkl, prints accuracy
"""
from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
G = 9.81
FREE_BOUNDS = '--no-free-bounds' not in sys.argv   # bounds also as inequalities on free phases (off: a free phase
# could ride the bound past its junction, the arc's length then undetermined; checked afterwards on a dense grid)
BOX = (0.02, 0.002) if '--no-box' not in sys.argv else (None, None)   # s, for N and 2N
CONTINUITY = '--no-continuity' not in sys.argv   # quantity continuous at each junction
BARYCENTRIC = '--barycentric' in sys.argv   # differentiation matrix by the barycentric formula (column sums 0 to
# 1e-15); the np.poly1d one below has column sums off by 1.3e-11 at degree 7, a bias ~eps*X/h per interval that
# grows with N (arm_sat: states 5e-7 apart between N = 30 and 60, J 1.9e-10 apart, J rising linearly in N)
BOUNDS = json.loads((HERE / "bounds.json").read_text())


def system(name):
    """Minimal-coordinate model: dict with f(x,u)->xdot, the bounded quantity g(x,u), the library's state
    values and multipliers as functions of (x,u)."""
    if name == "arm_sat":
        L1, m1, L2, m2 = 0.6, 1.0, 0.5, 0.7
        q = ca.SX.sym("q", 2); qd = ca.SX.sym("qd", 2); u = ca.SX.sym("u", 2)
        s1, c1, s2, c2 = ca.sin(q[0]), ca.cos(q[0]), ca.sin(q[1]), ca.cos(q[1])
        bodies = {"l1": (m1, m1 * L1**2 / 12, ca.vertcat(L1 / 2 * s1, -L1 / 2 * c1), q[0]),
                  "l2": (m2, m2 * L2**2 / 12, ca.vertcat(L1 * s1 + L2 / 2 * s2, -L1 * c1 - L2 / 2 * c2), q[1])}
        Q = ca.vertcat(u[0] - u[1], u[1])
        bound_expr = lambda x, a, uu: uu[0]
        T, x0, xf = 1.2, [0, 0, 0, 0], [1.6, 2.4, 0, 0]
        ulim = [(-BOUNDS[name], BOUNDS[name]), (-np.inf, np.inf)]
        inputs = ["tau1", "tau2"]
    elif name == "cart_force":
        mc, mp, L = 2.0, 0.5, 0.5
        q = ca.SX.sym("q", 2); qd = ca.SX.sym("qd", 2); u = ca.SX.sym("u", 1)
        bodies = {"cart": (mc, 0.01, ca.vertcat(q[0], 0), 0 * q[0]),
                  "pole": (mp, mp * L**2 / 12, ca.vertcat(q[0] + L / 2 * ca.sin(q[1]), -L / 2 * ca.cos(q[1])), q[1])}
        Q = ca.vertcat(u[0], 0)
        T, x0, xf = 2.0, [0, 0, 0, 0], [1.0, 0, 0, 0]
        ulim = [(-np.inf, np.inf)]
        inputs = ["push"]
    elif name == "rod_lower":
        m, L = 1.0, 1.0
        q = ca.SX.sym("q", 1); qd = ca.SX.sym("qd", 1); u = ca.SX.sym("u", 1)
        bodies = {"rod": (m, m * L**2 / 12, ca.vertcat(L / 2 * ca.sin(q[0]), -L / 2 * ca.cos(q[0])), q[0])}
        Q = u
        T, x0, xf = 1.5, [0, 0], [2.0, 0]
        ulim = [(-BOUNDS[name], np.inf)]
        inputs = ["motor"]
    n = q.shape[0]
    Tk = 0; V = 0; vel = {}; om = {}
    for b, (mb, Ib, p, ang) in bodies.items():
        v = ca.jtimes(p, q, qd); w = ca.jtimes(ang, q, qd)
        vel[b], om[b] = v, w
        Tk += 0.5 * mb * ca.dot(v, v) + 0.5 * Ib * w**2
        V += mb * G * p[1]
    Lg = Tk - V
    M = ca.jacobian(ca.jacobian(Lg, qd), qd)
    rhs = Q + ca.jacobian(Lg, q).T - ca.jacobian(ca.jacobian(Lg, qd).T, q) @ qd
    qdd = ca.solve(M, rhs)
    x = ca.vertcat(q, qd)
    f = ca.Function("f", [x, u], [ca.vertcat(qd, qdd)])
    acc = {b: ca.jacobian(vel[b], q) @ qd + ca.jacobian(vel[b], qd) @ qdd for b in bodies}
    gvec = ca.vertcat(0, -G)
    states, lams = {}, {}
    for b, (mb, Ib, p, ang) in bodies.items():
        z = 0 * q[0]
        states.update({f"{b}.x": p[0], f"{b}.y": p[1], f"{b}.z": z, f"{b}.psi": ang + z, f"{b}.theta": z,
                       f"{b}.phi": z, f"{b}.psi_dot": om[b] + z, f"{b}.theta_dot": z, f"{b}.phi_dot": z,
                       f"{b}.vbar_x": vel[b][0], f"{b}.vbar_y": vel[b][1], f"{b}.vbar_z": z,
                       f"{b}.omega_x": z, f"{b}.omega_y": z, f"{b}.omega_z": om[b] + z})
    z = 0 * q[0]
    if name == "arm_sat":
        Fe = m2 * (acc["l2"] - gvec)                    # on l2 from l1 at the elbow
        Fs = m1 * (acc["l1"] - gvec) + Fe               # on l1 from ground at the shoulder
        for j, F in (("shoulder", Fs), ("elbow", Fe)):
            lams.update({f"{j}.v1.lambda": F[0], f"{j}.v2.lambda": F[1], f"{j}.v3.lambda": z,
                         f"{j}.w1.lambda": z, f"{j}.w2.lambda": z})
        path = u[0]
    elif name == "cart_force":
        Fp = mp * (acc["pole"] - gvec)                  # on the pole from the cart
        Fr = mc * (acc["cart"] - gvec) - ca.vertcat(u[0], 0) + Fp   # on the cart from the rail (x: 0)
        lams.update({"pivot.v1.lambda": Fp[0], "pivot.v2.lambda": Fp[1], "pivot.v3.lambda": z,
                     "pivot.w1.lambda": z, "pivot.w2.lambda": z, "rail.n1.lambda": Fr[1], "rail.n2.lambda": z,
                     "rail.w1.lambda": z, "rail.w2.lambda": z, "rail.w3.lambda": z, "_rail_x_check": Fr[0]})
        path = Fp[0]
    else:
        F = m * (acc["rod"] - gvec)
        lams.update({"hinge.v1.lambda": F[0], "hinge.v2.lambda": F[1], "hinge.v3.lambda": z,
                     "hinge.w1.lambda": z, "hinge.w2.lambda": z})
        path = u[0]
    sn, ln = sorted(states), sorted(lams)
    return dict(f=f, n=n, nu=u.shape[0], T=T, x0=x0, xf=xf, ulim=ulim, inputs=inputs, bound=BOUNDS[name],
                path=ca.Function("g", [x, u], [path]),
                states=ca.Function("S", [x, u], [ca.vertcat(*[states[k] for k in sn])]), state_names=sn,
                lams=ca.Function("Lm", [x, u], [ca.vertcat(*[lams[k] for k in ln])]), lam_names=ln)


def radau(d, barycentric=None):
    tau = np.append(0, ca.collocation_points(d, "radau"))
    C = np.zeros((d + 1, d + 1)); B = np.zeros(d + 1)
    if BARYCENTRIC if barycentric is None else barycentric:
        w = np.array([1 / np.prod([tau[j] - tau[k] for k in range(d + 1) if k != j]) for j in range(d + 1)])
        D = np.zeros((d + 1, d + 1))
        for i in range(d + 1):
            for j in range(d + 1):
                if i != j:
                    D[i, j] = w[j] / w[i] / (tau[i] - tau[j])
            D[i, i] = -D[i].sum()              # the negative-sum trick: D @ 1 = 0 to rounding
        C[:] = D.T                              # C[j, r] = l_j'(tau_r)
    else:
        for j in range(d + 1):
            p = np.poly1d([1])
            for r in range(d + 1):
                if r != j:
                    p *= np.poly1d([1, -tau[r]]) / (tau[j] - tau[r])
            dp = np.polyder(p)
            for r in range(d + 1):
                C[j, r] = dp(tau[r])
    for j in range(1, d + 1):                       # Radau quadrature: the collocation points' own basis
        p = np.poly1d([1])
        for r in range(1, d + 1):
            if r != j:
                p *= np.poly1d([1, -tau[r]]) / (tau[j] - tau[r])
        B[j] = np.polyint(p)(1.0)
    return tau, C, B


def solve(name, phases, N, d, guess=None, box=None, continuity=None, fixed_durations=None, free_bounds=None):
    """phases: list of (kind, value) with kind 'free' or 'arc'; guess: dict(durations, xfun(t), ufun(t)).
    continuity: impose the quantity's continuity at each junction (default: CONTINUITY, i.e. on unless
    --no-continuity); fixed_durations: phase durations held fixed (e.g. from indirect.py), box then ignored;
    free_bounds: the bounds as inequalities on free phases (default FREE_BOUNDS)."""
    if continuity is None:
        continuity = CONTINUITY
    if free_bounds is None:
        free_bounds = FREE_BOUNDS
    S = system(name)
    n, nu, T = S["n"], S["nu"], S["T"]
    tau, C, B = radau(d)
    opti = ca.Opti()
    durs = opti.variable(len(phases))
    opti.subject_to(ca.sum1(durs) == T)
    opti.subject_to(durs >= 1e-3)
    if fixed_durations is not None:
        opti.subject_to(durs == ca.DM(np.asarray(fixed_durations, float)))
    elif box is not None:     # a trust box about the guess's durations: keeps a free phase from riding the bound
        opti.subject_to(opti.bounded(guess["durations"] - box, durs, guess["durations"] + box))
    J = 0
    Xprev = opti.variable(2 * n)
    opti.subject_to(Xprev == ca.DM(S["x0"]))
    nodes = []          # (phase, k, Xlist, Ulist)
    blim = S["bound"]
    for p, (kind, val) in enumerate(phases):
        h = durs[p] / N
        for k in range(N):
            Xc = [opti.variable(2 * n) for _ in range(d)]
            Uc = [opti.variable(nu) for _ in range(d)]
            Xall = [Xprev] + Xc
            for j in range(1, d + 1):
                xp = sum(C[r, j] * Xall[r] for r in range(d + 1))
                opti.subject_to(xp == h * S["f"](Xall[j], Uc[j - 1]))
                J += B[j] * h * ca.sumsqr(Uc[j - 1])
                g = S["path"](Xall[j], Uc[j - 1])
                for i, (lo, hi) in enumerate(S["ulim"]):
                    if name != "cart_force" and i == 0 and (kind == "arc" or not free_bounds):
                        continue
                    if np.isfinite(lo):
                        opti.subject_to(Uc[j - 1][i] >= lo)
                    if np.isfinite(hi):
                        opti.subject_to(Uc[j - 1][i] <= hi)
                if kind == "arc":
                    opti.subject_to(g == val)
                elif name == "cart_force" and free_bounds:
                    opti.subject_to(opti.bounded(-blim, g, blim))
            nodes.append((p, k, Xall, Uc))
            if continuity and kind == "free" and k == 0 and p > 0 and phases[p - 1][0] == "arc":
                w0 = _lagrange(tau[1:], np.eye(d), np.array([0.0]))[0]      # u extrapolated to the junction
                u0 = sum(w0[j] * Uc[j] for j in range(d))
                opti.subject_to(S["path"](Xall[0], u0) == phases[p - 1][1])
            if continuity and kind == "free" and k == N - 1 and p + 1 < len(phases) and phases[p + 1][0] == "arc":
                opti.subject_to(S["path"](Xall[d], Uc[d - 1]) == phases[p + 1][1])
            Xprev = Xc[-1]
    opti.subject_to(Xprev == ca.DM(S["xf"]))
    opti.minimize(J)
    if guess is not None:
        opti.set_initial(durs, guess["durations"])
        t0s = np.concatenate([[0], np.cumsum(guess["durations"])])
        for (p, k, Xall, Uc) in nodes:
            h = guess["durations"][p] / N
            for j in range(d + 1):
                tt = t0s[p] + (k + tau[j]) * h
                opti.set_initial(Xall[j], guess["xfun"](tt))
                if j:
                    opti.set_initial(Uc[j - 1], guess["ufun"](tt))
    opti.solver("ipopt", {"print_time": False}, {"tol": 1e-12, "print_level": 0, "max_iter": 3000,
                                                 "mu_strategy": "adaptive"})
    t0 = time.time()
    s = opti.solve()
    dv = np.array(s.value(durs)).ravel()
    t0s = np.concatenate([[0], np.cumsum(dv)])
    ivs = []
    for (p, k, Xall, Uc) in nodes:
        h = dv[p] / N
        ivs.append(dict(t0=t0s[p] + k * h, h=h, X=np.array([np.array(s.value(x)).ravel() for x in Xall]),
                        U=np.array([np.array(s.value(uu)).ravel() for uu in Uc])))
    return dict(name=name, phases=phases, N=N, d=d, durations=dv, junctions=list(t0s[1:-1]),
                objective=float(s.value(J)), intervals=ivs, stats=s.stats()["return_status"],
                wall_s=time.time() - t0)


def _lagrange(taus, vals, s):
    """vals: (len(taus), m); s: array in [0,1]; returns (len(s), m)."""
    out = np.zeros((len(s), vals.shape[1]))
    for j in range(len(taus)):
        Lj = np.ones(len(s))
        for r in range(len(taus)):
            if r != j:
                Lj *= (s - taus[r]) / (taus[j] - taus[r])
        out += Lj[:, None] * vals[j][None, :]
    return out


def evaluate(ref, times):
    """Reference states, multipliers, inputs (dicts of arrays) at times (s)."""
    S = system(ref["name"])
    tau, _, _ = radau(ref["d"])
    ivs = ref["intervals"]
    starts = np.array([iv["t0"] for iv in ivs])
    idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(ivs) - 1)
    X = np.zeros((len(times), 2 * S["n"])); U = np.zeros((len(times), S["nu"]))
    for i in np.unique(idx):
        m = idx == i
        iv = ivs[i]
        s = (times[m] - iv["t0"]) / iv["h"]
        X[m] = _lagrange(tau, iv["X"], s)
        U[m] = _lagrange(tau[1:], iv["U"], s)
    Sv = np.array(S["states"].map(len(times))(X.T, U.T))
    Lv = np.array(S["lams"].map(len(times))(X.T, U.T))
    states = {k: Sv[i] for i, k in enumerate(S["state_names"])}
    lams = {k: Lv[i] for i, k in enumerate(S["lam_names"]) if not k.startswith("_")}
    inputs = {k: U[:, i] for i, k in enumerate(S["inputs"])}
    path = np.array(S["path"].map(len(times))(X.T, U.T)).ravel()
    return states, lams, inputs, path


def structure_from_lib(name):
    """Arc structure and guess read off the library's fixed-mesh solution (Radau 60 x 5)."""
    sys.path.insert(0, str(HERE))
    import models
    import ocp_constraints as oc
    pb, P = models.build(name)
    sol = pb.solve(oc.Radau(60, degree=5))
    S = system(name)
    T = S["T"]
    t = np.linspace(0, T, 6001)
    qn = {"arm_sat": ["l1.psi", "l2.psi"], "cart_force": ["cart.x", "pole.psi"], "rod_lower": ["rod.psi"]}[name]
    qdn = {"arm_sat": ["l1.psi_dot", "l2.psi_dot"], "cart_force": ["cart.vbar_x", "pole.psi_dot"],
           "rod_lower": ["rod.psi_dot"]}[name]
    Xs = np.array([sol.interpolate(k, t) for k in qn + qdn])
    Us = np.array([sol.interpolate(k, t) for k in S["inputs"]])
    g = (np.array(sol.interpolate("pivot.v1.lambda", t)) if name == "cart_force" else Us[0])
    b = S["bound"]
    tol = 2e-3 * b
    state = np.where(np.abs(g - b) < tol, 1, np.where(np.abs(g + b) < tol, -1, 0))
    if name == "rod_lower":
        state[state == 1] = 0
    # runs shorter than 10 ms (the fixed mesh's barrier rounding next to a junction) take their neighbours' value
    for _ in range(5):
        edges = np.flatnonzero(np.diff(state)) + 1
        runs = np.split(np.arange(len(t)), edges)
        for r in runs:
            if t[r[-1]] - t[r[0]] < 0.01 and r[0] > 0 and r[-1] < len(t) - 1:
                state[r] = state[r[0] - 1]
    phases, durs, start = [], [], 0.0
    cur = state[0]
    for i in range(1, len(t)):
        if state[i] != cur or i == len(t) - 1:
            phases.append(("free", 0.0) if cur == 0 else ("arc", float(cur * b)))
            durs.append(t[i] - start); start = t[i]; cur = state[i]
    durs[-1] += T - sum(durs)
    guess = dict(durations=np.array(durs), xfun=lambda tt: np.array([np.interp(tt, t, r) for r in Xs]),
                 ufun=lambda tt: np.array([np.interp(tt, t, r) for r in Us]))
    return phases, guess


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("name"); ap.add_argument("--N", type=int, default=30); ap.add_argument("--degree", type=int, default=7); ap.add_argument("--no-continuity", action="store_true"); ap.add_argument("--no-free-bounds", action="store_true"); ap.add_argument("--no-box", action="store_true"); ap.add_argument("--barycentric", action="store_true"); ap.add_argument("--tag", default="")
    ap.add_argument("--indirect", action="store_true", help="junction times from indirect.py (necessary conditions, "
                    "seeded by the N solve), then N and 2N with those durations fixed, no continuity constraint and no bounds on "
                    "free phases (both then follow; checked: the input's gap at each junction, the dense bound check)")
    a = ap.parse_args()
    phases, guess = structure_from_lib(a.name)
    print("phases", phases, "guess durations", np.round(guess["durations"], 4))
    r1 = solve(a.name, phases, a.N, a.degree, guess, box=BOX[0])
    g2 = dict(durations=r1["durations"], xfun=lambda tt: _xfun(r1, tt),
              ufun=lambda tt: _ufun(r1, tt))
    if a.indirect:
        import indirect
        ind = indirect.solve(r1, verbose=False)
        print("indirect junctions", [float(x) for x in ind["junctions"]], "residual", ind["residual"],
              "J", ind["objective"])
        print("free-duration N junctions", [float(x) for x in r1["junctions"]], "J", r1["objective"])
        r1 = solve(a.name, phases, a.N, a.degree, g2, continuity=False, free_bounds=False,
                   fixed_durations=ind["durations"])
        g2 = dict(durations=r1["durations"], xfun=lambda tt: _xfun(r1, tt), ufun=lambda tt: _ufun(r1, tt))
        r2 = solve(a.name, phases, 2 * a.N, a.degree, g2, continuity=False, free_bounds=False,
                   fixed_durations=ind["durations"])
        for r in (r1, r2):      # the input's gap to the bound at each junction (continuity now a consequence)
            print("N", r["N"], "input at the junctions minus the arc value:", _junction_gaps(r))
    else:
        r2 = solve(a.name, phases, 2 * a.N, a.degree, g2, box=BOX[1])
    for r, bx, g in ((r1, BOX[0], guess["durations"]), (r2, BOX[1], r1["durations"])):
        edge = np.abs(np.abs(r["durations"] - g) - bx) < 1e-6 * max(bx, 1e-9)
        print("durations", r["N"], np.round(r["durations"], 9), "at the box edge:", bool(edge.any()))
    print(a.name, r1["stats"], r2["stats"], "J", r1["objective"], r2["objective"])
    print("junctions N ", r1["junctions"]); print("junctions 2N", r2["junctions"])
    t = np.unique(np.concatenate([np.linspace(0, r2["durations"].sum(), 8001)]))
    s1, l1, u1, g1 = evaluate(r1, t); s2, l2, u2, gg2 = evaluate(r2, t)
    ds = max(np.abs(s1[k] - s2[k]).max() for k in s1)
    scale = max(np.abs(v).max() for v in l2.values())
    dl = max(np.abs(l1[k] - l2[k]).max() for k in l1) / scale
    dj = max(abs(a_ - b_) for a_, b_ in zip(r1["junctions"], r2["junctions"])) if r1["junctions"] else 0.0
    b = BOUNDS[a.name]
    viol = float(max(0.0, (np.abs(gg2) - b).max())) if a.name != "rod_lower" else float(max(0.0, (-b - gg2).max()))
    acc = dict(states_N_vs_2N=ds, multipliers_N_vs_2N=dl, junctions_N_vs_2N=dj, load_scale=scale,
               bound_violation_dense=viol, objective=r2["objective"], J_N=r1["objective"])
    if a.name == "cart_force":
        S = system(a.name)
    print("accuracy", json.dumps(acc))
    r2["accuracy"] = acc
    with open(HERE / f"ref_{a.name}{a.tag}.pkl", "wb") as fh:
        pickle.dump(r2, fh)


def _junction_gaps(r):
    S = system(r["name"])
    tau, _, _ = radau(r["d"])
    N, ph = r["N"], r["phases"]
    out = []
    for j in range(len(ph) - 1):
        p = j if ph[j][0] == "free" else j + 1
        if ph[p][0] != "free" or ph[j + 1 if p == j else j][0] != "arc":
            continue
        iv = r["intervals"][p * N + (N - 1 if p == j else 0)]
        s = np.array([1.0 if p == j else 0.0])
        U = _lagrange(tau[1:], iv["U"], s)[0]
        X = _lagrange(tau, iv["X"], s)[0]
        arc = ph[j + 1][1] if p == j else ph[j][1]
        out.append(float(np.array(S["path"](X, U)).ravel()[0] - arc))
    return out


def _xfun(r, tt):
    S = system(r["name"])
    tau, _, _ = radau(r["d"])
    tt = float(tt)
    ivs = r["intervals"]
    i = max(0, min(len(ivs) - 1, int(np.searchsorted([iv["t0"] for iv in ivs], tt, side="right") - 1)))
    iv = ivs[i]
    return _lagrange(tau, iv["X"], np.array([(tt - iv["t0"]) / iv["h"]]))[0]


def _ufun(r, tt):
    tau, _, _ = radau(r["d"])
    tt = float(tt)
    ivs = r["intervals"]
    i = max(0, min(len(ivs) - 1, int(np.searchsorted([iv["t0"] for iv in ivs], tt, side="right") - 1)))
    iv = ivs[i]
    return _lagrange(tau[1:], iv["U"], np.array([(tt - iv["t0"]) / iv["h"]]))[0]


if __name__ == "__main__":
    main()
