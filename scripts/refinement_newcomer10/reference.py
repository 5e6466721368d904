"""Independent references in plain CasADi + NumPy (no library code): minimal-coordinate ODEs (Lagrange's equations),
Radau IIA collocation of degree d on N intervals per phase (phases with free durations where a path constraint holds
on an arc), IPOPT tol 1e-12. Evaluation between points by the collocation polynomials (states and their derivative)
and the degree d-1 polynomial through the input's collocation values.
"""
from __future__ import annotations

import casadi as ca
import numpy as np


def _radau(d):
    tau = np.concatenate([[0.0], np.asarray(ca.collocation_points(d, "radau"))])
    n = d + 1
    basis = []
    for j in range(n):
        p = np.poly1d([1.0])
        for r in range(n):
            if r != j:
                p *= np.poly1d([1.0, -tau[r]]) / (tau[j] - tau[r])
        basis.append(p)
    C = np.array([[basis[j].deriv()(tau[r]) for r in range(n)] for j in range(n)])   # C[j, r] = l_j'(tau_r)
    B = np.array([basis[j].integ()(1.0) for j in range(n)])
    ub = []   # input basis on the collocation points only
    for j in range(1, n):
        p = np.poly1d([1.0])
        for r in range(1, n):
            if r != j:
                p *= np.poly1d([1.0, -tau[r]]) / (tau[j] - tau[r])
        ub.append(p)
    return tau, basis, C, B, ub


class Reference:
    """spec: nx, nu, f(x,u)->xdot, L(x,u) (integrand), x0 / xT (lists, None = free), phases: list of dicts
    {N, dur (guess), eq: optional g(x,u) held = 0 on the phase, ineq: optional list of (g, lo, hi)},
    T (fixed horizon) or T_free=(lo, hi) with time_weight, guess_x(t)->list, guess_u(t)->list, ubounds (lo, hi)
    lists or None."""

    def __init__(self, spec, N_scale=1, d=7):
        self.s = spec
        self.d = d
        self.N_scale = N_scale

    def solve(self, tol=1e-12, max_iter=3000, print_level=0):
        s, d = self.s, self.d
        tau, basis, C, B, ub = _radau(d)
        opti = ca.Opti()
        nx, nu = s["nx"], s["nu"]
        phases = s["phases"]
        durs = [opti.variable() for _ in phases]
        Tfree = "T_free" in s
        for p, v in zip(phases, durs):
            opti.set_initial(v, p["dur"])
            opti.subject_to(v >= 1e-3)
        Ttot = sum(durs) if len(durs) > 1 else durs[0]
        if Tfree:
            opti.subject_to(opti.bounded(s["T_free"][0], Ttot, s["T_free"][1]))
        else:
            opti.subject_to(Ttot == s["T"])
        J = 0
        Xk = opti.variable(nx)
        x0 = s["x0"]
        for i, v in enumerate(x0):
            if v is not None:
                opti.subject_to(Xk[i] == v)
        self.layout = []
        t_guess = 0.0
        Xstore, Ustore = [], []
        for ip, (p, dur) in enumerate(zip(phases, durs)):
            N = p["N"] * self.N_scale
            h = dur / N
            hg = p["dur"] / N
            for k in range(N):
                Xc = [opti.variable(nx) for _ in range(d)]
                Uc = [opti.variable(nu) for _ in range(d)]
                Xall = [Xk] + Xc
                for j in range(d + 1):
                    tj = t_guess + (k + tau[j]) * hg
                    opti.set_initial(Xall[j], s["guess_x"](tj))
                    if j > 0:
                        opti.set_initial(Uc[j - 1], s["guess_u"](tj))
                for r in range(1, d + 1):
                    xp = sum(C[j, r] * Xall[j] for j in range(d + 1))
                    x, u = Xall[r], Uc[r - 1]
                    opti.subject_to(xp == h * s["f"](x, u))
                    J = J + h * B[r] * s["L"](x, u)
                    if s.get("ubounds"):
                        lo, hi = s["ubounds"]
                        for i in range(nu):
                            if np.isfinite(lo[i]):
                                opti.subject_to(u[i] >= lo[i])
                            if np.isfinite(hi[i]):
                                opti.subject_to(u[i] <= hi[i])
                    if p.get("eq") is not None:
                        opti.subject_to(p["eq"](x, u) == 0)
                    for g, lo, hi in p.get("ineq", []):
                        gx = g(x, u)
                        if np.isfinite(lo):
                            opti.subject_to(gx >= lo)
                        if np.isfinite(hi):
                            opti.subject_to(gx <= hi)
                if k == 0 and ip > 0 and s.get("u_continuous"):
                    # the input continuous across a junction (true of the optimum: the effort term makes the
                    # Hamiltonian strictly convex in u); without it the free junction time is barely determined
                    # (mintime: u jumped 8.5e-4 N m there, the junction 3.8e-6 s apart between N and 2N)
                    opti.subject_to(sum(float(ub[j](0.0)) * Uc[j] for j in range(d)) == Ustore[-1][-1])
                Xstore.append(Xall)
                Ustore.append(Uc)
                self.layout.append((ip, k, N))
                Xk = Xc[-1]
            t_guess += p["dur"]
        for i, v in enumerate(s["xT"]):
            if v is not None:
                opti.subject_to(Xk[i] == v)
        if Tfree:
            J = J + s.get("time_weight", 1.0) * Ttot
        opti.minimize(J)
        opti.solver("ipopt", {"print_time": False}, {"tol": tol, "max_iter": max_iter, "print_level": print_level,
                                                      "mu_strategy": "adaptive",
                                                      "acceptable_iter": 100000})   # no "acceptable" exits
        self.opti = opti
        sol = opti.solve()
        self.status = opti.stats()["return_status"]
        self.J = float(sol.value(J))
        self.durs = [float(sol.value(v)) for v in durs]
        self.T = float(sum(self.durs))
        self.X = [np.column_stack([np.atleast_1d(sol.value(x)) for x in Xall]) for Xall in Xstore]   # nx x (d+1)
        self.U = [np.column_stack([np.atleast_1d(sol.value(u)) for u in Uc]) for Uc in Ustore]      # nu x d
        self.basis, self.ub = basis, ub
        self.dbasis = [b.deriv() for b in basis]
        # interval start times and lengths
        starts, hs = [], []
        t0 = 0.0
        for ip, p in enumerate(phases):
            N = p["N"] * self.N_scale
            h = self.durs[ip] / N
            for k in range(N):
                starts.append(t0 + k * h)
                hs.append(h)
            t0 += self.durs[ip]
        self.starts, self.hs = np.array(starts), np.array(hs)
        self.junctions = list(np.cumsum(self.durs)[:-1])
        return self

    def evaluate(self, t):
        """x, xdot, u at times t (s)."""
        t = np.atleast_1d(np.asarray(t, float))
        idx = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.starts) - 1)
        nx, nu = self.X[0].shape[0], self.U[0].shape[0]
        x, xd, u = np.zeros((nx, t.size)), np.zeros((nx, t.size)), np.zeros((nu, t.size))
        for k in np.unique(idx):
            m = idx == k
            sk = (t[m] - self.starts[k]) / self.hs[k]
            Lb = np.array([b(sk) for b in self.basis])
            dLb = np.array([b(sk) for b in self.dbasis]) / self.hs[k]
            Ub = np.array([b(sk) for b in self.ub])
            x[:, m] = self.X[k] @ Lb
            xd[:, m] = self.X[k] @ dLb
            u[:, m] = self.U[k] @ Ub
        return x, xd, u
