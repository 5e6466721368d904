"""Independent reference for the five-bar: minimal coordinates (the two crank angles), coupler angles from the loop
closure in closed form (intersection of two circles, the branch with P to the left of A1->A2), Lagrange's equations,
own Radau IIA collocation (degree 7) in casadi.Opti, IPOPT tol 1e-12. With the path constraint y_P <= H (a ceiling: the unconstrained optimum rises
to 0.561 m between end heights 0.442 and 0.373 m), three
phases with free durations: free / on the line (y_P'' = 0 at the collocation points, y_P = H and y_P' = 0 at the
entry) / free. Joint forces by Newton-Euler on the reference motion (12 equations, 10 unknown forces; the residual
is printed).

    python fivebar_ref.py free N          # unconstrained optimum (one phase, N intervals), prints min y_P
    python fivebar_ref.py ref N1 N2 N3    # constrained, phases of N1/N2/N3 intervals, then 2x; prints differences,
                                          # saves the finer as ref_fivebar.pkl (and the free one as ref_fivebar_free.pkl)
"""
from __future__ import annotations

import json
import math
import pickle
import sys
from pathlib import Path

import casadi as ca
import numpy as np
from numpy.polynomial import legendre as L

from models import FB, G

HERE = Path(__file__).resolve().parent
DEG = 7


def _geom(th, lib=ca):
    a, b, d = FB["a"], FB["b"], FB["d"]
    A1 = (a * lib.cos(th[0]), a * lib.sin(th[0]))
    A2 = (d + a * lib.cos(th[1]), a * lib.sin(th[1]))
    dx, dy = A2[0] - A1[0], A2[1] - A1[1]
    r2 = dx * dx + dy * dy
    r = lib.sqrt(r2)
    h = lib.sqrt(b * b - r2 / 4)
    P = (A1[0] + dx / 2 - h * dy / r, A1[1] + dy / 2 + h * dx / r)
    phi1 = lib.atan2(P[1] - A1[1], P[0] - A1[0])
    phi2 = lib.atan2(P[1] - A2[1], P[0] - A2[0])
    return A1, A2, P, phi1, phi2


def angles(th):
    A1, A2, P, p1, p2 = _geom(th, np)
    return (th[0], th[1], float(p1), float(p2))


def h_line():
    p = HERE / "h_line.json"
    return json.loads(p.read_text())["H"]


def sym():
    a, b, rho = FB["a"], FB["b"], FB["rho"]
    ma, mb = rho * a, rho * b
    Ia, Ib = ma * a**2 / 12, mb * b**2 / 12
    q = ca.SX.sym("q", 2)
    w = ca.SX.sym("w", 2)
    wd = ca.SX.sym("wd", 2)
    u = ca.SX.sym("u", 2)
    A1, A2, P, p1, p2 = _geom([q[0], q[1]])
    A1, A2, P = (ca.vertcat(*A1), ca.vertcat(*A2), ca.vertcat(*P))
    O1, O2 = ca.DM([0, 0]), ca.DM([FB["d"], 0])
    com = [(O1 + A1) / 2, (O2 + A2) / 2, (A1 + P) / 2, (A2 + P) / 2]
    ang = [q[0], q[1], p1, p2]
    mass = [ma, ma, mb, mb]
    inert = [Ia, Ia, Ib, Ib]
    vel = [ca.jtimes(c, q, w) for c in com]
    om = [ca.jtimes(g, q, w) for g in ang]
    Tk = sum(0.5 * mass[i] * ca.dot(vel[i], vel[i]) + 0.5 * inert[i] * om[i] ** 2 for i in range(4))
    V = sum(mass[i] * G * com[i][1] for i in range(4))
    Lg = Tk - V
    M = ca.hessian(Tk, w)[0]
    dLdw = ca.gradient(Lg, w)
    rhs = u + ca.gradient(Lg, q) - ca.jacobian(dLdw, q) @ w
    acc = ca.solve(M, rhs)
    f = ca.Function("f", [q, w, u], [acc])
    yP = P[1]
    dyP = ca.jtimes(yP, q, w)
    ddyP = ca.jtimes(dyP, ca.vertcat(q, w), ca.vertcat(w, acc))
    Y = ca.Function("Y", [q, w, u], [yP, dyP, ddyP])
    # kinematics for the library's names and Newton-Euler
    X = ca.vertcat(q, w)
    Xd = ca.vertcat(w, wd)
    cv = [ca.jtimes(c, q, w) for c in com]
    ca_ = [ca.jtimes(v, X, Xd) for v in cv]
    al = [ca.jtimes(o, X, Xd) for o in om]
    kin = ca.Function("kin", [q, w, wd], [ca.horzcat(*com), ca.vertcat(*ang), ca.horzcat(*cv), ca.vertcat(*om),
                                          ca.horzcat(*ca_), ca.vertcat(*al), A1, A2, P])
    return f, Y, kin, mass, inert


def radau(d):
    # Radau IIA points: roots of P_d(x) - P_{d-1}(x) on [-1, 1] mapped to (0, 1]
    cd = np.zeros(d + 1); cd[d] = 1
    cd1 = np.zeros(d + 1); cd1[d - 1] = 1
    x = np.sort(np.real(L.legroots(cd - cd1)))
    tau = np.concatenate([[0.0], (x + 1) / 2])
    n = d + 1
    D = np.zeros((n, n))
    C = np.zeros(n)          # quadrature weights on the collocation points (tau[1:])
    for j in range(n):
        others = [tau[k] for k in range(n) if k != j]
        pj = np.poly1d(np.poly(others)) / np.prod([tau[j] - o for o in others])
        dp = np.polyder(pj)
        D[:, j] = dp(tau)
        C[j] = np.polyint(pj)(1.0)
    return tau, D, C


CONTINUITY = False   # set by --continuity


def solve(Ns, constrained, guess=None, H=None, fix=None):
    """Ns: intervals per phase (1 or 3 phases). Returns dict with the nodes and values."""
    f, Y, *_ = sym()
    tau, D, C = radau(DEG)
    T = FB["T"]
    th0, thT = FB["th0"], FB["thT"]
    opti = ca.Opti()
    nph = len(Ns)
    dur = opti.variable(nph) if nph > 1 else None
    if nph > 1:
        opti.subject_to(ca.sum1(dur) == T)
        opti.subject_to(dur >= 1e-3 * T)
        if fix is not None:   # {phase index: duration}: junction held at a given time (sensitivity check)
            for i_, v_ in fix.items():
                opti.subject_to(dur[i_] == v_)
    durs = [dur[i] for i in range(nph)] if nph > 1 else [T]
    J = 0
    phases = []
    xprev = None
    for ph, N in enumerate(Ns):
        h = durs[ph] / N
        Xs = [opti.variable(4, DEG + 1) for _ in range(N)]   # column 0: interval start
        Us = [opti.variable(2, DEG) for _ in range(N)]
        for k in range(N):
            Xk, Uk = Xs[k], Us[k]
            if k == 0 and xprev is not None:
                opti.subject_to(Xk[:, 0] == xprev)
            elif k > 0:
                opti.subject_to(Xk[:, 0] == Xs[k - 1][:, DEG])
            for j in range(1, DEG + 1):
                xd = sum(Xk[:, i] * D[j, i] for i in range(DEG + 1))
                acc = f(Xk[0:2, j], Xk[2:4, j], Uk[:, j - 1])
                opti.subject_to(xd == h * ca.vertcat(Xk[2:4, j], acc))
                J += h * C[j] * ca.sumsqr(Uk[:, j - 1])
                yv = Y(Xk[0:2, j], Xk[2:4, j], Uk[:, j - 1])
                if constrained and nph == 3 and ph == 1:
                    opti.subject_to(yv[2] == 0)
                elif constrained:
                    opti.subject_to(yv[0] <= H)
            if constrained and nph == 3 and ph == 1 and k == 0:
                y0 = Y(Xk[0:2, 0], Xk[2:4, 0], Uk[:, 0])
                opti.subject_to(y0[0] == H)
                opti.subject_to(y0[1] == 0)
        xprev = Xs[-1][:, DEG]
        phases.append((Xs, Us))
    if constrained and nph == 3 and CONTINUITY:
        # Both torques continuous at each junction (a necessary condition: the integrand is strictly convex in them;
        # Jacobson, Lele and Speyer 1971): without it J is flat in the junction times, which moved 5e-6 s between
        # 60x3 and 120x3 (ref_fivebar_uncertainty.txt). The phase's last point is its end; the next phase's inputs
        # are extrapolated to its start through its first interval's collocation points.
        nodes = tau[1:]
        ell = [float(np.prod([(0.0 - nodes[r]) / (nodes[j] - nodes[r]) for r in range(DEG) if r != j])) for j in range(DEG)]
        for ph in (0, 1):
            end = phases[ph][1][-1][:, DEG - 1]
            start = sum(ell[j] * phases[ph + 1][1][0][:, j] for j in range(DEG))
            opti.subject_to(end == start)
    opti.subject_to(phases[0][0][0][:, 0] == ca.DM([th0[0], th0[1], 0, 0]))
    opti.subject_to(xprev == ca.DM([thT[0], thT[1], 0, 0]))
    opti.minimize(J)
    # guess
    if guess is None:
        for ph, (Xs, Us) in enumerate(phases):
            for k, Xk in enumerate(Xs):
                for j in range(DEG + 1):
                    s = (k + tau[j]) / len(Xs)
                    opti.set_initial(Xk[:, j], [th0[0] + (thT[0] - th0[0]) * s, th0[1] + (thT[1] - th0[1]) * s, 0, 0])
    else:
        tg, xg, ug, dg = guess
        starts = np.concatenate([[0], np.cumsum(dg)])
        if nph > 1:
            opti.set_initial(dur, dg)
        for ph, (Xs, Us) in enumerate(phases):
            N = len(Xs)
            for k in range(N):
                for j in range(DEG + 1):
                    t = starts[ph] + dg[ph] * (k + tau[j]) / N
                    opti.set_initial(Xs[k][:, j], [np.interp(t, tg, xg[i]) for i in range(4)])
                    if j:
                        opti.set_initial(Us[k][:, j - 1], [np.interp(t, tg, ug[i]) for i in range(2)])
    opti.solver("ipopt", {"print_time": False}, {"tol": 1e-12, "acceptable_iter": 0, "max_iter": 3000,
                                                   "print_level": 0, "sb": "yes", "mu_strategy": "adaptive"})
    sol = opti.solve()
    st = sol.stats()
    out = {"Ns": list(Ns), "deg": DEG, "tau": tau, "J": float(sol.value(J)), "status": st["return_status"],
           "iters": st["iter_count"], "H": H}
    dvals = [float(v) for v in np.atleast_1d(sol.value(dur))] if nph > 1 else [T]
    out["durs"] = dvals
    out["phases"] = [([np.asarray(sol.value(X)) for X in Xs], [np.asarray(sol.value(U)).reshape(2, DEG) for U in Us])
                     for Xs, Us in phases]
    return out


class Dense:
    """Evaluation of a reference between its nodes: states by the interval's Lagrange polynomial through tau[0..d],
    inputs by the polynomial through the collocation points tau[1..d]."""

    def __init__(self, r):
        self.r = r
        self.tau = np.asarray(r["tau"])
        self.edges = []
        t0 = 0.0
        for (Xs, Us), du in zip(r["phases"], r["durs"]):
            N = len(Xs)
            for k in range(N):
                self.edges.append((t0 + du * k / N, t0 + du * (k + 1) / N, Xs[k], Us[k]))
            t0 += du
        self.junctions = list(np.cumsum(r["durs"])[:-1])

    @staticmethod
    def _lag(nodes, vals, s):
        out = np.zeros((vals.shape[0], len(s)))
        for j in range(len(nodes)):
            lj = np.ones_like(s)
            for m_ in range(len(nodes)):
                if m_ != j:
                    lj *= (s - nodes[m_]) / (nodes[j] - nodes[m_])
            out += vals[:, j:j + 1] * lj
        return out

    def __call__(self, t):
        t = np.asarray(t, float)
        X = np.zeros((4, len(t)))
        U = np.zeros((2, len(t)))
        starts = np.array([e[0] for e in self.edges])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.edges) - 1)
        for k in np.unique(idx):
            a, b, Xk, Uk = self.edges[k]
            m = idx == k
            s = (t[m] - a) / (b - a)
            X[:, m] = self._lag(self.tau, Xk, s)
            U[:, m] = self._lag(self.tau[1:], Uk, s)
        return X, U


def quantities(dense, t):
    f, Y, kin, mass, inert = sym()
    X, U = dense(t)
    q, w = X[0:2], X[2:4]
    wd = np.asarray(f(q, w, U))
    st, loads = {}, {}
    names = ["crank1", "crank2", "coupler1", "coupler2"]
    zero = np.zeros(len(t))
    com = np.zeros((4, 2, len(t)))
    ang = np.zeros((4, len(t)))
    cv = np.zeros((4, 2, len(t)))
    om = np.zeros((4, len(t)))
    cacc = np.zeros((4, 2, len(t)))
    al = np.zeros((4, len(t)))
    A1 = np.zeros((2, len(t))); A2 = np.zeros((2, len(t))); P = np.zeros((2, len(t)))
    for n in range(len(t)):
        r = [np.asarray(v) for v in kin(q[:, n], w[:, n], wd[:, n])]
        com[:, :, n] = r[0].T; ang[:, n] = r[1].ravel(); cv[:, :, n] = r[2].T; om[:, n] = r[3].ravel()
        cacc[:, :, n] = r[4].T; al[:, n] = r[5].ravel(); A1[:, n] = r[6].ravel(); A2[:, n] = r[7].ravel(); P[:, n] = r[8].ravel()
    for i, nm in enumerate(names):
        st.update({f"{nm}.x": com[i, 0], f"{nm}.y": com[i, 1], f"{nm}.z": zero, f"{nm}.psi": ang[i],
                   f"{nm}.theta": zero, f"{nm}.phi": zero, f"{nm}.vbar_x": cv[i, 0], f"{nm}.vbar_y": cv[i, 1],
                   f"{nm}.vbar_z": zero, f"{nm}.omega_x": zero, f"{nm}.omega_y": zero, f"{nm}.omega_z": om[i]})
    # Newton-Euler, unknowns F_O1, F_O2, F_A1 (on coupler1), F_A2 (on coupler2), F_P (on coupler2)
    O1 = np.zeros((2, len(t))); O2 = np.zeros((2, len(t))); O2[0] = FB["d"]
    Fsol = np.zeros((10, len(t)))
    resid = 0.0

    def cross(r, col):   # z of r x F as row coefficients of F (fx, fy)
        return np.array([-r[1], r[0]])
    for n in range(len(t)):
        Aq = np.zeros((12, 10)); bq = np.zeros(12)
        # body rows: 3 per body (fx, fy, mz); unknown blocks: O1 0:2, O2 2:4, A1 4:6, A2 6:8, P 8:10
        terms = {0: [(0, 1, O1), (4, -1, A1)], 1: [(2, 1, O2), (6, -1, A2)],
                 2: [(4, 1, A1), (8, -1, P)], 3: [(6, 1, A2), (8, 1, P)]}
        for i in range(4):
            for (c0, sg, pt) in terms[i]:
                Aq[3 * i:3 * i + 2, c0:c0 + 2] += sg * np.eye(2)
                rr = pt[:, n] - com[i, :, n]
                Aq[3 * i + 2, c0:c0 + 2] += sg * cross(rr, None)
            bq[3 * i:3 * i + 2] = mass[i] * cacc[i, :, n] - mass[i] * np.array([0, -G])
            bq[3 * i + 2] = inert[i] * al[i, n] - (U[i, n] if i < 2 else 0.0)
        x, *_ = np.linalg.lstsq(Aq, bq, rcond=None)
        resid = max(resid, float(np.abs(Aq @ x - bq).max()))
        Fsol[:, n] = x
    loads = {"O1.F_x": Fsol[0], "O1.F_y": Fsol[1], "O2.F_x": Fsol[2], "O2.F_y": Fsol[3],
             "A1@coupler1.F_x": Fsol[4], "A1@coupler1.F_y": Fsol[5], "A1@crank1.F_x": -Fsol[4], "A1@crank1.F_y": -Fsol[5],
             "A2@coupler2.F_x": Fsol[6], "A2@coupler2.F_y": Fsol[7], "A2@crank2.F_x": -Fsol[6], "A2@crank2.F_y": -Fsol[7],
             "P@coupler2.F_x": Fsol[8], "P@coupler2.F_y": Fsol[9], "P@coupler1.F_x": -Fsol[8], "P@coupler1.F_y": -Fsol[9]}
    for ch in ("O1", "O2", "A1@coupler1", "A1@crank1", "A2@coupler2", "A2@crank2", "P@coupler2", "P@coupler1"):
        loads[f"{ch}.F_z"] = zero
    return st, loads, {"tau1": U[0], "tau2": U[1]}, resid, P


class Stored:
    def __init__(self, name):
        d = pickle.loads((HERE / f"ref_{name}.pkl").read_bytes())
        self.dense = Dense(d["fine"])
        self.junctions = self.dense.junctions
        self.uncertainty = d["uncertainty"]

    def quantities(self, t):
        st, loads, inp, _, _ = quantities(self.dense, t)
        return st, loads, inp


def compare(r1, r2, T):
    t = np.linspace(0, T, 3001)
    j = Dense(r2).junctions
    t = np.unique(np.concatenate([t] + [[x - 1e-9, x + 1e-9] for x in j]))
    s1, l1, i1, res1, P1 = quantities(Dense(r1), t)
    s2, l2, i2, res2, P2 = quantities(Dense(r2), t)
    ds = max(float(np.abs(s1[k] - s2[k]).max()) for k in s1)
    big = max(float(np.abs(v).max()) for v in l2.values())
    dl = max(float(np.abs(l1[k] - l2[k]).max()) for k in l1) / big
    ui = max(float(np.abs(i2[k]).max()) for k in i2)
    du = max(float(np.abs(i1[k] - i2[k]).max()) for k in i1) / ui
    return dict(states=ds, loads_rel=dl, inputs_rel=du, largest_load=big, NE_residual=max(res1, res2),
                J=(r1["J"], r2["J"]), durs=(r1["durs"], r2["durs"]), min_yP=float(P2[1].min()))


if __name__ == "__main__":
    a = sys.argv[1:]
    if "--continuity" in a:         # the torques continuous at the junctions (solve()); saved as ref_fivebar.pkl all the same
        a.remove("--continuity")
        CONTINUITY = True
    T = FB["T"]
    if a[0] == "free":
        N = int(a[1])
        r1 = solve([N], False)
        r2 = solve([2 * N], False)
        c = compare(r1, r2, T)
        print("free", r1["status"], r2["status"], json.dumps(c))
        t = np.linspace(0, T, 2001)
        _, _, _, _, P = quantities(Dense(r2), t)
        print("y_P: start", P[1][0], "end", P[1][-1], "min", P[1].min(), "at", t[P[1].argmin()])
        unc = {k: c[k] for k in ("states", "loads_rel", "inputs_rel")}
        (HERE / "ref_fivebar_free.pkl").write_bytes(pickle.dumps({"fine": r2, "coarse": r1, "uncertainty": unc}))
    elif a[0] == "ref":
        Ns = [int(x) for x in a[1:4]]
        H = h_line()
        # guess: one phase, the ceiling as an inequality at every collocation point (60 intervals); the arc's
        # guess is where it sits on the ceiling within 1e-6 m
        r0 = solve([60], True, None, H)
        df = Dense(r0)
        tg = np.linspace(0, T, 4001)
        Xg, Ug = df(tg)
        _, _, _, _, Pg = quantities(df, tg)
        on = tg[np.abs(Pg[1] - H) < 1e-6]
        dg = [on[0], on[-1] - on[0], T - on[-1]]
        print("one-phase inequality solve:", r0["status"], "J", r0["J"], "guess durations", dg, flush=True)
        r1 = solve(Ns, True, (tg, Xg, Ug, dg), H)
        print("N", Ns, r1["status"], r1["iters"], r1["J"], r1["durs"], flush=True)
        r2 = solve([2 * n for n in Ns], True, (tg, Xg, Ug, r1["durs"]), H)
        print("2N", r2["status"], r2["iters"], r2["J"], r2["durs"], flush=True)
        c = compare(r1, r2, T)
        print("ref", json.dumps(c))
        unc = {k: c[k] for k in ("states", "loads_rel", "inputs_rel")}
        unc["junction_shift_s"] = float(np.abs(np.cumsum(r1["durs"]) - np.cumsum(r2["durs"])).max())
        (HERE / "ref_fivebar.pkl").write_bytes(pickle.dumps({"fine": r2, "coarse": r1, "uncertainty": unc}))
