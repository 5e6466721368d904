"""Independent references (plain CasADi, no ocp_constraints): three phases (free arc, bound arc, free arc) with free
junction times, the middle phase solved exactly (the bound held as an equality: its ODE's solution in closed form),
the free arcs by Radau IIA collocation (s stages, N uniform intervals per phase), IPOPT tol 1e-12."""
from __future__ import annotations

import importlib.util
import os
import sys

import casadi as ca
import numpy as np

# Radau IIA's coefficients from the earlier newcomer checks' reference helpers (plain CasADi and NumPy, no library code).
_spec = importlib.util.spec_from_file_location(
    "newcomer_reference", os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "newcomer_reference.py"))
_reference = sys.modules["newcomer_reference"] = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_reference)
_radau_coefficients = _reference.radau_coefficients


class Phases:
    """spec: f(x,u) -> xdot (casadi), L(x,u) integrand, x0, xT (lists; None = free), entry(x) -> expressions = 0 at
    the arc's entry, middle(x, d) -> (x after the arc, cost of the arc), path(x) >= 0 on the free arcs, T,
    guess t1, t2, guess_x(t) -> list, nx, nu."""

    def __init__(self, spec: dict, N: int, s: int = 5):
        self.spec, self.N, self.s = spec, N, s
        tau, self.C, self.B = _radau_coefficients(s)        # tests/newcomer_reference.py's, over the nodes 0, tau
        self.tau = np.r_[0.0, tau]

    def basis(self, x: np.ndarray) -> np.ndarray:
        """Lagrange basis over self.tau at points x (in [0, 1]): shape (len(x), s+1)."""
        tau = self.tau
        out = np.ones((len(x), len(tau)))
        for j in range(len(tau)):
            for r in range(len(tau)):
                if r != j:
                    out[:, j] *= (x - tau[r]) / (tau[j] - tau[r])
        return out

    def solve(self, warm=None, fix_t1=None, continuity=False):
        """continuity: the input continuous at both junctions (a necessary condition where the integrand is strictly
        convex in it, Jacobson, Lele and Speyer 1971), which fixes the junction times where J is flat in them."""
        sp, N, s = self.spec, self.N, self.s
        nx, nu, T = sp["nx"], sp["nu"], sp["T"]
        opti = ca.Opti()
        t1 = opti.variable()
        t2 = opti.variable()
        opti.subject_to(opti.bounded(1e-3, t1, T - 2e-3))
        opti.subject_to(opti.bounded(t1 + 1e-3, t2, T - 1e-3))
        opti.set_initial(t1, sp["t1"])
        if fix_t1 is not None:
            opti.subject_to(t1 == fix_t1)
        opti.set_initial(t2, sp["t2"])
        X, U, J = [], [], 0
        for ph, (a, b) in enumerate(((0.0, t1), (t2, T))):
            Xp = opti.variable(nx, N * s + 1)
            Up = opti.variable(nu, N * s)
            h = (b - a) / N
            for k in range(N):
                xs = Xp[:, k * s:(k + 1) * s + 1]
                for j in range(1, s + 1):
                    xp = sum(self.C[r, j] * xs[:, r] for r in range(s + 1))
                    uj = Up[:, k * s + j - 1]
                    opti.subject_to(xp == h * sp["f"](xs[:, j], uj))
                    J = J + h * self.B[j] * sp["L"](xs[:, j], uj)
                    if sp.get("path") is not None:
                        opti.subject_to(sp["path"](xs[:, j]) >= 0)
            X.append(Xp)
            U.append(Up)
            # guesses
            a0, b0 = (0.0, sp["t1"]) if ph == 0 else (sp["t2"], T)
            tt = []
            for k in range(N):
                tt += [a0 + (b0 - a0) * (k + self.tau[j]) / N for j in range(0 if k == 0 else 1, s + 1)]
            opti.set_initial(Xp, np.array([sp["guess_x"](t) for t in tt]).T)
            opti.set_initial(Up, sp.get("guess_u", 0.0))
        for i, v in enumerate(sp["x0"]):
            if v is not None:
                opti.subject_to(X[0][i, 0] == v)
        for i, v in enumerate(sp["xT"]):
            if v is not None:
                opti.subject_to(X[1][i, -1] == v)
        xe = X[0][:, -1]
        opti.subject_to(sp["entry"](xe) == 0)
        x2, cmid = sp["middle"](xe, t2 - t1)
        opti.subject_to(X[1][:, 0] == x2)
        if continuity:
            hold = ca.vertcat(*sp["u_arc"](xe))
            opti.subject_to(U[0][:, -1] == hold)         # the last Radau point of the first free arc is t1
            tr = self.tau[1:]
            w = [np.prod([(0.0 - tr[r]) / (tr[j] - tr[r]) for r in range(s) if r != j]) for j in range(s)]
            opti.subject_to(sum(w[j] * U[1][:, j] for j in range(s)) == hold)   # the second's polynomial at t2
        J = J + cmid
        opti.minimize(J)
        if warm is not None:
            opti.set_initial(t1, warm["t1"])
            opti.set_initial(t2, warm["t2"])
        opti.solver("ipopt", {"print_time": False}, {"tol": 1e-12, "print_level": 0, "max_iter": 3000,
                                                      "mu_strategy": "adaptive"})
        sol = opti.solve()
        self.t1, self.t2 = float(sol.value(t1)), float(sol.value(t2))
        self.X = [np.atleast_2d(sol.value(x)) for x in X]
        self.U = [np.atleast_2d(sol.value(u)) for u in U]
        self.J = float(sol.value(J))
        return self

    def evaluate(self, t: np.ndarray):
        """x (nx, n), u (nu, n) at times t: the collocation polynomial on the free arcs (u: the polynomial through the
        s Radau points), the middle phase's exact solution on the arc."""
        sp, N, s = self.spec, self.N, self.s
        t = np.asarray(t, float)
        x = np.zeros((sp["nx"], len(t)))
        u = np.zeros((sp["nu"], len(t)))
        on = np.zeros(len(t), bool)
        for ph, (a, b) in enumerate(((0.0, self.t1), (self.t2, sp["T"]))):
            m = (t >= a) & (t <= b) if ph == 0 else (t >= a) & (t <= b + 1e-15)
            if ph == 1:
                m &= ~on
            on |= m
            if not m.any():
                continue
            z = (t[m] - a) / (b - a) * N
            k = np.clip(np.floor(z).astype(int), 0, N - 1)
            loc = z - k
            Bx = self.basis(loc)
            Xp, Up = self.X[ph], self.U[ph]
            idx = k[:, None] * s + np.arange(s + 1)[None, :]
            x[:, m] = np.einsum("ij,nij->ni", Bx, Xp[:, idx])
            # u: Lagrange through the s Radau points only
            tr = self.tau[1:]
            Bu = np.ones((len(loc), s))
            for j in range(s):
                for r in range(s):
                    if r != j:
                        Bu[:, j] *= (loc - tr[r]) / (tr[j] - tr[r])
            iu = k[:, None] * s + np.arange(s)[None, :]
            u[:, m] = np.einsum("ij,nij->ni", Bu, Up[:, iu])
        mid = ~on
        if mid.any():
            xe = self.X[0][:, -1]
            for i in np.flatnonzero(mid):
                d = t[i] - self.t1
                x2, _ = sp["middle"](ca.DM(xe), d)
                x[:, i] = np.asarray(ca.DM(x2)).ravel()
                u[:, i] = sp["u_arc"](x[:, i])
        return x, u
