"""An independent multi-phase reference for the least-time gantry crane (scripts/newcomer_problems.py: crane()).

    python scripts/crane_reference/reference.py --runs 8:12 8:24 7:24 [--mid 0] [--out DIR]

Nothing of ocp_constraints: the crane's Lagrange equations are written out here by hand (coordinates x, psi;
checked against scripts' own `ref` module, npb.crane_system(), at random states), transcribed in plain CasADi
Opti and solved by IPOPT (tol = compl_inf_tol = constr_viol_tol = 1e-12, no "acceptable" exit).

Phases (fractions of T in the library's solution): F = +200 | tension arc | free | tension arc, first half |
tension arc, second half | free | tension arc | F = -200. Eight phases, each of duration d_p (a decision
variable, T = sum d_p), each N uniform Radau-IIA intervals of degree K; states continuous across phases, the
input per collocation point (discontinuous across phases allowed). In a phase its active bound is an equality
at every collocation point (F = +-200, or |F_rope|^2 = f_max^2), the other bounds inequalities. The middle
tension arc (which passes through plumb, where d|F_rope|^2/dF = 0) is split in two phases at the point where
psi = 0 (imposed: psi at the common node = 0, which fixes the split); the collocation points within ``--mid``
intervals of the split (the split point itself always) keep the tension as an inequality |F_rope|^2 <= f_max^2.

A run "K:N" is degree K, N intervals per phase. Each run starts from the previous one (the first from a
uniform single-phase Radau-3 solve of the same equations, all bounds inequalities). Each solution is saved
to DIR/ref_K_N.npz (phase boundaries, X, W) for compare.py.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).parent
M1, M2, J2, L, G = 10.0, 50.0, 0.5, 3.0, 9.81        # trolley, load mass (kg), load inertia (kg m^2), rope (m), g
FMAX, D, SWING = 200.0, 2.0, 0.3
TMAX2 = (1.05 * M2 * G) ** 2                            # N^2
FRACS = [0.0, 0.01904447, 0.2108313, 0.3020983, 0.5, 0.6979015, 0.7891686, 0.9809555, 1.0]
KINDS = ["F+", "arc", "free", "arcA", "arcB", "free", "arc", "F-"]
T_GUESS = 2.6443


# -- equations of motion, by hand --------------------------------------------------------------------------
def crane_functions():
    """x = (x, psi, xd, psid), F -> x', the rope's force on the load (fixed basis, N, 2D), its square.

    T = 1/2 M1 xd^2 + 1/2 M2 |v_load|^2 + 1/2 J2 psid^2, load at (x + L sin psi, -L cos psi), V = -M2 G L cos psi:
        (M1 + M2) xdd + M2 L cos(psi) psidd - M2 L sin(psi) psid^2 = F
        M2 L cos(psi) xdd + (M2 L^2 + J2) psidd + M2 G L sin(psi) = 0
    The rope's force on the load (Newton on the load): M2 (a_load - g)."""
    s = ca.SX.sym("s", 4)
    F = ca.SX.sym("F")
    x, psi, xd, psid = s[0], s[1], s[2], s[3]
    c, sn = ca.cos(psi), ca.sin(psi)
    Mm = ca.vertcat(ca.horzcat(M1 + M2, M2 * L * c), ca.horzcat(M2 * L * c, M2 * L**2 + J2))
    rhs = ca.vertcat(F + M2 * L * sn * psid**2, -M2 * G * L * sn)
    acc = ca.solve(Mm, rhs)
    xdd, psidd = acc[0], acc[1]
    a = ca.vertcat(xdd + L * c * psidd - L * sn * psid**2, L * sn * psidd + L * c * psid**2)
    rope = M2 * (a - ca.vertcat(0, -G))
    f = ca.Function("f", [s, F], [ca.vertcat(xd, psid, xdd, psidd)])
    R = ca.Function("rope", [s, F], [rope])
    R2 = ca.Function("rope2", [s, F], [ca.sumsqr(rope)])
    return f, R, R2


def check_against_ref(n=200, seed=1) -> float:
    """Largest difference of (xdd, psidd) and the rope force from scripts' `ref` module (npb.crane_system())."""
    sys.path.insert(0, str(HERE.parent))
    import newcomer_problems as npb  # scripts' own Lagrange module, independent of the library
    s = npb.crane_system()
    qdd = ca.Function("qdd", [s.q, s.qd, s.w], [s.qdd])
    v = ca.jtimes(s.bodies[1].x, s.q, s.qd)
    qddsym = ca.SX.sym("a", 2)
    Fr = ca.Function("Fr", [s.q, s.qd, qddsym], [M2 * (ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, qddsym) - ca.DM(s.gravity))])
    f, R, _ = crane_functions()
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        st = rng.uniform([-1, -0.5, -3, -2], [3, 0.5, 3, 2])
        u = rng.uniform(-200, 200)
        a_ref = np.asarray(qdd(st[:2], st[2:], u)).ravel()
        a_me = np.asarray(f(st, u)).ravel()[2:]
        F_ref = np.asarray(Fr(st[:2], st[2:], a_ref)).ravel()[:2]
        F_me = np.asarray(R(st, u)).ravel()
        worst = max(worst, np.abs(a_ref - a_me).max(), np.abs(F_ref - F_me).max())
    return worst


# -- Radau ------------------------------------------------------------------------------------------------
def radau(K):
    tau = np.array(ca.collocation_points(K, "radau"))
    nodes = np.r_[0.0, tau]
    C = np.zeros((K + 1, K + 1))
    B = np.zeros(K + 1)
    for j in range(K + 1):
        p = np.poly1d([1.0])
        for r in range(K + 1):
            if r != j:
                p *= np.poly1d([1.0, -nodes[r]]) / (nodes[j] - nodes[r])
        dp = np.polyder(p)
        for r in range(K + 1):
            C[j, r] = dp(nodes[r])
        B[j] = np.polyint(p)(1.0)
    return tau, C, B


GRADE = "cheb"


def phase_mesh(N, grade=None):
    """Interval fractions within a phase: uniform, or clustered at both ends (Chebyshev-Lobatto points)."""
    grade = GRADE if grade is None else grade
    i = np.arange(N + 1)
    return i / N if grade == "uniform" else 0.5 * (1 - np.cos(np.pi * i / N))


def basis(nodes, s):
    """Lagrange basis of ``nodes`` at ``s``: len(s) x len(nodes)."""
    s = np.atleast_1d(s)
    out = np.ones((len(s), len(nodes)))
    for j, a in enumerate(nodes):
        for r, b in enumerate(nodes):
            if r != j:
                out[:, j] *= (s - b) / (a - b)
    return out


class PhaseSolution:
    """Radau-K on phases with boundaries ``bounds`` (s), N intervals each; state(t), push(t), rope(t) between points."""

    def __init__(self, bounds, N, K, X, W, **meta):
        self.bounds, self.N, self.K, self.X, self.W = np.asarray(bounds, float), N, K, np.asarray(X), np.atleast_2d(W)
        self.meta = meta
        self.T = float(self.bounds[-1])
        self.tau = np.array(ca.collocation_points(K, "radau"))
        P = len(self.bounds) - 1
        self.grade = meta.get("grade", GRADE)
        m = phase_mesh(N, self.grade)
        self.starts = np.concatenate([self.bounds[p] + (self.bounds[p + 1] - self.bounds[p]) * m[:-1] for p in range(P)])
        self.ends = np.r_[self.starts[1:], self.bounds[-1]]
        self.t = np.concatenate([[0.0], (self.starts[:, None] + (self.ends - self.starts)[:, None] * self.tau[None, :]).ravel()])
        _, self._R, self._R2 = crane_functions()

    def _where(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.starts) - 1)
        return t, k, (t - self.starts[k]) / (self.ends[k] - self.starts[k])

    def state(self, t):
        t, k, s = self._where(t)
        nodes = np.r_[0.0, self.tau]
        Bm = basis(nodes, s)
        idx = k[:, None] * self.K + np.arange(self.K + 1)[None, :]
        return np.einsum("inj,nj->in", self.X[:, idx], Bm)

    def push(self, t):
        t, k, s = self._where(t)
        Bm = basis(self.tau, s)
        idx = k[:, None] * self.K + np.arange(self.K)[None, :]
        return np.einsum("nj,nj->n", FMAX * self.W[0, idx], Bm)

    def rope(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        return np.asarray(self._R.map(len(t))(self.state(t), self.push(t)[None, :]))

    # normalized time
    def state_n(self, u):
        return self.state(np.asarray(u) * self.T)

    def push_n(self, u):
        return self.push(np.asarray(u) * self.T)

    def rope_n(self, u):
        return self.rope(np.asarray(u) * self.T)

    def save(self, path):
        np.savez(path, bounds=self.bounds, N=self.N, K=self.K, X=self.X, W=self.W, meta=json.dumps(self.meta, default=float))

    @classmethod
    def load(cls, path):
        z = np.load(path)
        return cls(z["bounds"], int(z["N"]), int(z["K"]), z["X"], z["W"], **json.loads(str(z["meta"])))


CONTINUOUS = True
FREE_GAP = 1e-3    # in a free phase's inner intervals |F_rope|^2 <= (1 - FREE_GAP) f_max^2 (checked: inactive)


def solve(kinds, N, K, guess, bounds_guess, mid=0, tol=1e-12, max_iter=3000, print_level=None):
    import os
    print_level = int(os.environ.get("REF_PRINT", "0")) if print_level is None else print_level
    """``kinds``: per phase 'F+', 'F-', 'arc', 'arcA', 'arcB', 'free' or 'ineq' (all bounds inequalities).
    ``guess(t) -> (X 4 x n, F n)``; ``bounds_guess``: phase boundaries (s)."""
    f, R, R2 = crane_functions()
    tau, C, B = radau(K)
    P = len(kinds)
    opti = ca.Opti()
    d = opti.variable(P)
    opti.subject_to(d >= 1e-4)
    T = ca.sum1(d)
    opti.subject_to(opti.bounded(0.5, T, 20.0))
    n = P * N * K
    X = opti.variable(4, n + 1)
    U = opti.variable(1, n)                     # F / FMAX
    J = T
    eq_t, ineq_t, free_u, gap_t = [], [], [], []
    split = None
    mfr = phase_mesh(N)
    for p, kind in enumerate(kinds):
        for kk in range(N):
            h = d[p] * (mfr[kk + 1] - mfr[kk])
            k = p * N + kk
            cols = [X[:, k * K + j] for j in range(K + 1)]
            for j in range(1, K + 1):
                xp = sum(C[r, j] * cols[r] for r in range(K + 1))
                u = U[0, k * K + j - 1]
                opti.subject_to(xp == h * f(cols[j], FMAX * u))
                J += 1e-6 * FMAX**2 * h * B[j] * u**2
                g = (R2(cols[j], FMAX * u) - TMAX2) / TMAX2
                opti.subject_to(opti.bounded(-SWING, cols[j][1], SWING))
                if kind in ("F+", "F-"):
                    opti.subject_to(u == (1.0 if kind == "F+" else -1.0))
                    ineq_t.append(g)
                else:
                    free_u.append(u)
                    near = (kind == "arcA" and (kk >= N - mid or (kk == N - 1 and j == K))) or \
                           (kind == "arcB" and kk < mid)
                    if kind in ("arc", "arcA", "arcB") and not near:
                        eq_t.append(g)
                    elif kind == "free" and 0 < kk < N - 1 and FREE_GAP:
                        gap_t.append(g + FREE_GAP)    # a free phase may not host the arc (but at its ends)
                    else:
                        ineq_t.append(g)
        if kind == "arcA":
            split = (p + 1) * N * K
    if eq_t:
        c_eq = ca.vertcat(*eq_t) == 0
        opti.subject_to(c_eq)
    if ineq_t:
        opti.subject_to(ca.vertcat(*ineq_t) <= 0)
    if gap_t:
        opti.subject_to(ca.vertcat(*gap_t) <= 0)
    if free_u:
        opti.subject_to(opti.bounded(-1.0, ca.vertcat(*free_u), 1.0))
    if split is not None:
        opti.subject_to(X[1, split] == 0)
    if CONTINUOUS:   # F continuous across the phase boundaries: the first interval's F polynomial at its start
        at_start = basis(tau, np.array([0.0]))[0]
        for p in range(1, P):
            if kinds[p] == "arcB" or (CONTINUOUS is not True and p not in CONTINUOUS):
                continue             # the split inside the middle arc: pinned by psi = 0 already
            k = p * N
            opti.subject_to(U[0, k * K - 1] == ca.dot(ca.DM(at_start), U[0, k * K:(k + 1) * K].T))
    opti.subject_to(X[:, 0] == 0)
    opti.subject_to(X[:, -1] == ca.DM([D, 0, 0, 0]))
    # guess
    bg = np.asarray(bounds_guess, float)
    starts = np.concatenate([bg[p] + (bg[p + 1] - bg[p]) * mfr[:-1] for p in range(P)])
    ends = np.r_[starts[1:], bg[-1]]
    tt = np.concatenate([[0.0], (starts[:, None] + (ends - starts)[:, None] * tau[None, :]).ravel()])
    Xg, Fg = guess(tt)
    opti.set_initial(X, Xg)
    opti.set_initial(U, np.clip(np.asarray(Fg).ravel()[1:] / FMAX, -1, 1)[None, :])
    opti.set_initial(d, np.diff(bg))
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False},
                {"print_level": print_level, "sb": "yes", "tol": tol, "compl_inf_tol": tol, "constr_viol_tol": tol,
                 "acceptable_iter": 0, "max_iter": max_iter, "mu_strategy": "adaptive"})
    t0 = time.process_time()
    try:
        sol = opti.solve()
        ok = True
    except RuntimeError:
        sol = opti.debug
        ok = False
    cpu = time.process_time() - t0
    stats = opti.stats()
    dv = np.asarray(sol.value(d)).ravel()
    bounds = np.r_[0.0, np.cumsum(dv)]
    eqv = np.asarray(sol.value(ca.vertcat(*eq_t))).ravel() if eq_t else np.zeros(0)
    inv = np.asarray(sol.value(ca.vertcat(*ineq_t))).ravel() if ineq_t else np.zeros(0)
    meta = dict(kinds=list(kinds), mid=mid, grade=GRADE, continuous=CONTINUOUS if CONTINUOUS in (True, False) else sorted(CONTINUOUS), ok=ok, status=stats["return_status"], iterations=int(stats["iter_count"]),
                objective=float(sol.value(J)), T=float(bounds[-1]), cpu=cpu,
                eq_residual=float(np.abs(eqv).max()) if len(eqv) else 0.0,
                ineq_max=float(inv.max()) if len(inv) else -1.0, free_gap=FREE_GAP,
                free_inner_max=float(np.max(sol.value(ca.vertcat(*gap_t)))) - FREE_GAP if gap_t else None)
    if ok and eq_t:
        lam = np.asarray(sol.value(opti.dual(c_eq))).ravel()
        meta.update(arc_dual_min=float(lam.min()), arc_dual_max=float(lam.max()))
    return PhaseSolution(bounds, N, K, np.asarray(sol.value(X)), np.atleast_2d(sol.value(U)), **meta)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", nargs="+", default=["8:12", "8:24", "7:24"], help="K:N, solved in this order")
    ap.add_argument("--mid", type=int, default=0, help="intervals either side of the split with the tension as inequality")
    ap.add_argument("--out", type=Path, default=HERE / "refs")
    ap.add_argument("--tag", default="")
    ap.add_argument("--grade", default="cheb", choices=["cheb", "uniform"], help="intervals within a phase")
    ap.add_argument("--jumps", action="store_true", help="no F continuity across phase boundaries")
    ap.add_argument("--free-gap", type=float, default=FREE_GAP, help="0: free phases with the plain inequality")
    args = ap.parse_args()
    global GRADE, CONTINUOUS, FREE_GAP
    GRADE, CONTINUOUS, FREE_GAP = args.grade, not args.jumps, args.free_gap
    args.out.mkdir(exist_ok=True)
    print(f"hand-written equations against scripts' ref module: largest difference {check_against_ref():.1e}")
    # 1. a uniform single-phase solve for a first guess
    t0 = time.time()
    z = lambda tt: (np.vstack([D * tt / T_GUESS, 0 * tt, 0 * tt + D / T_GUESS, 0 * tt]), 0 * tt)  # noqa: E731
    g, GRADE = GRADE, "uniform"
    uni = solve(["ineq"], 60, 3, z, [0.0, T_GUESS], tol=1e-8)
    GRADE = g
    print(f"uniform Radau-3, 60 intervals: {uni.meta['status']}, T = {uni.T:.9f}, J = {uni.meta['objective']:.10f} "
          f"({time.time() - t0:.0f} s)")
    prev = uni
    bounds_guess = np.array(FRACS) * uni.T
    for run in args.runs:
        K, N = map(int, run.split(":"))
        t0 = time.time()

        def guess(tt, prev=prev):
            return prev.state(tt * prev.T / bounds_guess[-1]), prev.push(tt * prev.T / bounds_guess[-1])
        if prev is uni and CONTINUOUS:    # first the phases without F continuity (finds the arcs), then with it
            CONTINUOUS = False
            r0 = solve(KINDS, N, K, guess, bounds_guess, mid=args.mid)
            CONTINUOUS = True
            print(f"  without F continuity first: {r0.meta['status']}, T = {r0.T:.12f}", flush=True)

            def guess(tt, prev=r0):
                return prev.state(tt), prev.push(tt)
            bounds_guess = r0.bounds
        r = solve(KINDS, N, K, guess, bounds_guess, mid=args.mid)
        m = r.meta
        print(f"K={K} N={N} mid={args.mid}: {m['status']} ({m['iterations']} it, {time.time() - t0:.0f} s), T = {r.T:.12f}, "
              f"J = {m['objective']:.13f}; junctions/T = " + ", ".join(f"{b / r.T:.9f}" for b in r.bounds[1:-1]) +
              f"; eq residual {m['eq_residual']:.1e}, largest inequality {m['ineq_max']:.1e}; arc duals "
              f"{m.get('arc_dual_min', float('nan')):.2e}..{m.get('arc_dual_max', float('nan')):.2e}", flush=True)
        r.save(args.out / f"ref_{K}_{N}_m{args.mid}_{GRADE}{'_jumps' if args.jumps else ''}{args.tag}.npz")
        if m["ok"]:
            prev, bounds_guess = r, r.bounds


if __name__ == "__main__":
    main()
