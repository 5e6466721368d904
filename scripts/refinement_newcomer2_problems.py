"""A second newcomer's problems for ``solve(tolerance=...)`` (models through the public API of ocp_constraints,
each with a reference computed independently of the library), used by scripts/refinement_newcomer2_check.py.

Problems
  lq, lq2, lq3, lq4 : block on a prismatic rail (zero gravity), push F at an offset h along body E2,
                      min int (q x^2 + r F^2), x(0) = x0, v(0) = 0, x(T) = xT, v(T) = 0. lq2 adds a real layer at
                      t = T (xT != 0); lq3 and lq4 sharpen both layers (rates with real part 15.8 and 50 1/s).
                      Reference: the linear Hamiltonian system solved exactly with the matrix exponential.
  pend, pend2       : rod on a revolute joint in gravity, rest to rest 0 -> 100 deg in T (1.5 s, 3 s), min int tau^2.
                      Reference: scipy solve_bvp on Pontryagin's equations, polished by Newton shooting with DOP853.
  mayer             : the block, min w (x(T) - D)^2 + int F^2 from rest, x(T), v(T) free: a terminal cost through
                      problem.minimize_terminal. Closed form (F linear in t); the objective is the full J.

The rail's moment multiplier rail.w3 = h F is the block problems' one non-zero constraint load.

    python scripts/refinement_newcomer2_problems.py --scan-pend2    # re-derive pend2's costate seed (about a minute)
"""
from __future__ import annotations

import math
import sys

import numpy as np
import scipy.linalg as sla
from scipy.integrate import solve_bvp, solve_ivp

LQ = dict(m=0.8, h=0.15, q=2500.0, r=1.0, T=2.0, x0=0.5, xT=0.0)
LQ2 = dict(LQ, xT=-0.3)
LQ3 = dict(LQ, q=1e4, m=0.2, xT=-0.3)
LQ4 = dict(LQ, q=1e6, m=0.2, xT=-0.3)     # stress: layers of about 1% of the horizon
LQS = {"lq": LQ, "lq2": LQ2, "lq3": LQ3, "lq4": LQ4}
PEND = dict(m=1.0, L=0.8, g=9.81, T=1.5, Theta=math.radians(100.0))
# On the 3 s horizon solve_bvp from the simple guess lands on a poor extremal (J about 148). The seed is the
# initial costate (p1, p2) of the best extremal found by scan_pend2_seeds() below (J 1.31288).
PEND2 = dict(PEND, T=3.0, seed_p0=(-1.43906479, 0.21477641))
PENDS = {"pend": PEND, "pend2": PEND2}
MAYER = dict(m=1.2, h=0.1, w=50.0, D=1.0, T=1.5)
PROBLEMS = (*LQS, *PENDS, "mayer")

BLOCK_ZERO_STATES = ["block.y", "block.z", "block.psi", "block.theta", "block.phi", "block.vbar_y", "block.vbar_z",
                     "block.omega_x", "block.omega_y", "block.omega_z"]
BLOCK_ZERO_LAMBDAS = ["rail.n1.lambda", "rail.n2.lambda", "rail.w1.lambda", "rail.w2.lambda"]
ROD_ZERO_STATES = ["rod.z", "rod.theta", "rod.phi", "rod.theta_dot", "rod.phi_dot", "rod.vbar_z", "rod.omega_x",
                   "rod.omega_y"]


def gauss_integral(f, a, b, panels=400, n=16):
    """int_a^b f by composite Gauss-Legendre (the references are smooth: far below any tolerance checked)."""
    x, w = np.polynomial.legendre.leggauss(n)
    edges = np.linspace(a, b, panels + 1)
    return sum(0.5 * (hi - lo) * float(np.sum(w * f(0.5 * (hi - lo) * x + 0.5 * (hi + lo))))
               for lo, hi in zip(edges[:-1], edges[1:]))


# ----------------------------------------------------------------------------------------------- models
# The first newcomer's block (scripts/refinement_newcomer_problems.py): pushed off its centre of mass, so the rail's
# moment multiplier carries h F.
from refinement_newcomer_problems import block_model, rod_problem  # noqa: E402  (scripts/ is on sys.path: this file's folder)


def build(problem):
    """A fresh OptimalControlProblem for ``problem`` (one of PROBLEMS)."""
    import ocp_constraints as oc

    if problem in LQS:
        p = LQS[problem]
        ocp = oc.OptimalControlProblem(block_model(p, problem), t_final=p["T"])
        ocp.initial({"block.x": p["x0"], "block.vbar_x": 0.0})
        ocp.final({"block.x": p["xT"], "block.vbar_x": 0.0})
        ocp.minimize_integral(p["q"] * ocp.quantity("block.x") ** 2 + p["r"] * ocp.quantity("F") ** 2, label="lq")
        return ocp
    if problem in PENDS:
        p = PENDS[problem]
        return rod_problem(problem, p["m"], p["L"], p["g"], p["T"], p["Theta"])
    if problem == "mayer":
        p = MAYER
        ocp = oc.OptimalControlProblem(block_model(p, "mayer"), t_final=p["T"])
        ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
        ocp.minimize_terminal(p["w"] * (ocp.quantity("block.x") - p["D"]) ** 2)
        ocp.minimize_effort(["F"])
        return ocp
    raise ValueError(f"unknown problem {problem!r}; one of {PROBLEMS}")


# ----------------------------------------------------------------------------------------------- references
class LQRef:
    """The Hamiltonian system z' = A z, z = [x, v, p1, p2], solved exactly: H = q x^2 + r F^2 + p1 v + p2 F / m gives
    F = -p2 / (2 r m), p1' = -2 q x, p2' = -p1. Multiple shooting on K segments (z_{k+1} = expm(A h) z_k, one linear
    system) because single shooting is ill-conditioned for the sharp layers of lq3/lq4; z(t) = expm(A (t - t_k)) z_k."""

    def __init__(self, p, K=64):
        self.p = p
        m, q, r, T = p["m"], p["q"], p["r"], p["T"]
        self.A = np.array([[0, 1, 0, 0], [0, 0, 0, -1 / (2 * r * m * m)], [-2 * q, 0, 0, 0], [0, 0, -1, 0]], float)
        self.nodes = np.linspace(0.0, T, K + 1)
        E = sla.expm(self.A * (T / K))
        n = 4 * (K + 1)
        M, b = np.zeros((n, n)), np.zeros(n)
        for k in range(K):
            M[4 * k:4 * k + 4, 4 * k:4 * k + 4] = E
            M[4 * k:4 * k + 4, 4 * k + 4:4 * k + 8] = -np.eye(4)
        for row, (col, val) in enumerate(((0, p["x0"]), (1, 0.0), (4 * K, p["xT"]), (4 * K + 1, 0.0)), start=4 * K):
            M[row, col], b[row] = 1.0, val
        self.Z = np.linalg.solve(M, b).reshape(K + 1, 4)

    def z(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.searchsorted(self.nodes, t, side="right") - 1, 0, len(self.nodes) - 2)
        return np.array([sla.expm(self.A * (ti - self.nodes[ki])) @ self.Z[ki] for ti, ki in zip(t, k)])

    def motion(self, t):
        z = self.z(t)
        return z[:, 0], z[:, 1], -z[:, 3] / (2 * self.p["r"] * self.p["m"])

    def objective(self):
        q, r = self.p["q"], self.p["r"]
        return gauss_integral(lambda t: (lambda x, v, F: q * x**2 + r * F**2)(*self.motion(t)), 0.0, self.p["T"],
                              panels=100, n=20)


def pend_rhs(p):
    """Pontryagin's equations for the rod, y = [th, w, p1, p2]: tau = -p2 / (2 J), w' = tau / J - k sin th."""
    J = p["m"] * p["L"] ** 2 / 3
    k = p["m"] * p["g"] * (p["L"] / 2) / J

    def rhs(t, y):
        th, w, p1, p2 = y
        return np.array([w, -p2 / (2 * J * J) - k * np.sin(th), p2 * k * np.cos(th), -p1])
    return rhs, J, k


def shoot_ivp(rhs, T, p0, tol, dense=False):
    return solve_ivp(rhs, (0, T), [0.0, 0.0, p0[0], p0[1]], method="DOP853", rtol=tol, atol=tol, dense_output=dense)


class PendRef:
    def __init__(self, p, tol=1e-10, nodes=200):
        self.p = p
        T, Th = p["T"], p["Theta"]
        rhs, self.J, self.k = pend_rhs(p)       # vectorised: solve_bvp passes columns, solve_ivp vectors
        bc = lambda ya, yb: np.array([ya[0], ya[1], yb[0] - Th, yb[1]])
        t = np.linspace(0, T, nodes)
        if "seed_p0" in p:
            y = shoot_ivp(rhs, T, p["seed_p0"], 1e-10, dense=True).sol(t)
        else:                                               # a smooth rest-to-rest guess, costates zero
            th = Th * (t / T - np.sin(2 * np.pi * t / T) / (2 * np.pi))
            y = np.vstack([th, np.gradient(th, t), np.zeros_like(t), np.zeros_like(t)])
        coarse = solve_bvp(rhs, bc, t, y, tol=1e-5, max_nodes=200000)       # continuation in tol (long horizon)
        assert coarse.success, coarse.message
        bvp_tol = tol
        bvp = solve_bvp(rhs, bc, coarse.x, coarse.y, tol=bvp_tol, max_nodes=500000, bc_tol=1e-12)
        while not bvp.success and bvp_tol < 1e-7:         # pend2 does not reach 1e-10: the shooting below polishes
            bvp_tol *= 10
            bvp = solve_bvp(rhs, bc, coarse.x, coarse.y, tol=bvp_tol, max_nodes=500000, bc_tol=1e-12)
        assert bvp.success, bvp.message
        p0 = bvp.sol(0.0)[2:4].copy()

        def residual(pp):
            s = shoot_ivp(rhs, T, pp, 1e-13)
            return np.array([s.y[0, -1] - Th, s.y[1, -1]])
        for _ in range(6):                                  # Newton on the initial costates, finite-difference Jacobian
            r0 = residual(p0)
            d = 1e-6 * np.maximum(1.0, np.abs(p0))
            jac = np.column_stack([(residual(p0 + d[j] * np.eye(2)[j]) - r0) / d[j] for j in range(2)])
            p0 = p0 - np.linalg.solve(jac, r0)
        self.shoot_residual = float(np.max(np.abs(residual(p0))))
        assert self.shoot_residual < 1e-9, self.shoot_residual
        self.ivp = shoot_ivp(rhs, T, p0, 1e-13, dense=True)

    def y(self, t):
        return self.ivp.sol(np.asarray(t, float))

    def objective(self):
        return gauss_integral(lambda t: (self.y(t)[3] / (2 * self.J)) ** 2, 0.0, self.p["T"])


class MayerRef:
    """Pontryagin: p1 constant, p2(T) = 0, so F = c (T - t), x(T) = c T^3 / (3 m); transversality p1 = 2 w (x(T) - D)
    gives c (1 + w T^3 / (3 m^2)) = w D / m. J = w (x(T) - D)^2 + int F^2: the full objective, terminal term
    included."""

    def __init__(self, p):
        self.p = p
        m, w, D, T = p["m"], p["w"], p["D"], p["T"]
        self.c = (w * D / m) / (1 + w * T**3 / (3 * m * m))
        self.J = w * (self.c * T**3 / (3 * m) - D) ** 2 + self.c**2 * T**3 / 3

    def motion(self, t):
        t = np.asarray(t, float)
        c, m, T = self.c, self.p["m"], self.p["T"]
        return c * (T * t**2 / 2 - t**3 / 6) / m, c * (T * t - t**2 / 2) / m, c * (T - t)


def reference(problem):
    """(T, objective_ref, f) with f(t) -> (states, inputs, multipliers), each a dict sample name -> array."""
    if problem in LQS or problem == "mayer":
        p = LQS.get(problem, MAYER)
        R = LQRef(p) if problem in LQS else MayerRef(p)
        obj = R.objective() if problem in LQS else R.J

        def f(t):
            t = np.asarray(t, float)
            x, v, F = R.motion(t)
            z = np.zeros_like(t)
            states = {"block.x": x, "block.vbar_x": v, **{n: z for n in BLOCK_ZERO_STATES}}
            loads = {"rail.w3.lambda": p["h"] * F, **{n: z for n in BLOCK_ZERO_LAMBDAS}}
            return states, {"F": F}, loads
        return p["T"], obj, f
    if problem in PENDS:
        p = PENDS[problem]
        R = PendRef(p)
        m, g, r = p["m"], p["g"], p["L"] / 2

        def f(t):
            t = np.asarray(t, float)
            th, w, _, p2 = R.y(t)
            tau = -p2 / (2 * R.J)
            al = tau / R.J - R.k * np.sin(th)
            s, c = np.sin(th), np.cos(th)
            z = np.zeros_like(t)
            # centre of mass at (r sin th, -r cos th), hinge at the origin, rod hanging at th = 0
            states = {"rod.psi": th, "rod.psi_dot": w, "rod.omega_z": w, "rod.x": r * s, "rod.y": -r * c,
                      "rod.vbar_x": r * w * c, "rod.vbar_y": r * w * s, **{n: z for n in ROD_ZERO_STATES}}
            # hinge force on the rod = m a_com - m gvec, gvec = (0, -g, 0)
            Fx = m * (r * al * c - r * w**2 * s)
            Fy = m * (r * al * s + r * w**2 * c) + m * g
            loads = {"hinge.v1.lambda": Fx, "hinge.v2.lambda": Fy, "hinge.v3.lambda": z,
                     "hinge.w1.lambda": z, "hinge.w2.lambda": z}
            return states, {"motor": tau}, loads
        return p["T"], R.objective(), f
    raise ValueError(f"unknown problem {problem!r}; one of {PROBLEMS}")


def scan_pend2_seeds():
    """Independent search for pend2's best extremal: Newton shooting (DOP853) from a 9 x 9 grid of initial costates;
    prints every distinct extremal with its cost, best first. The best one is PEND2's seed_p0."""
    p = PEND2
    rhs, J, _ = pend_rhs(p)
    T, Th = p["T"], p["Theta"]

    def residual(pp):
        s = shoot_ivp(rhs, T, pp, 1e-9)
        return np.array([s.y[0, -1] - Th, s.y[1, -1]])

    def cost(pp):
        tt = np.linspace(0, T, 3001)
        return float(np.trapezoid((shoot_ivp(rhs, T, pp, 1e-11, dense=True).sol(tt)[3] / (2 * J)) ** 2, tt))
    found = []
    for a in np.linspace(-6, 6, 9):
        for b in np.linspace(-3, 3, 9):
            pp = np.array([a, b])
            for _ in range(15):
                r0 = residual(pp)
                if np.max(np.abs(r0)) < 1e-9:
                    if not any(np.allclose(pp, q, atol=1e-5) for q, _ in found):
                        found.append((pp, cost(pp)))
                    break
                jac = np.column_stack([(residual(pp + 1e-6 * e) - r0) / 1e-6 for e in np.eye(2)])
                try:
                    step = np.linalg.solve(jac, -r0)
                except np.linalg.LinAlgError:
                    break
                pp = pp + step * min(1.0, 20 / np.max(np.abs(step)))      # damped: the costate map is far from linear
    for pp, c in sorted(found, key=lambda item: item[1]):
        print("p0", pp, "J", c)


if __name__ == "__main__":
    if sys.argv[1:] == ["--scan-pend2"]:
        scan_pend2_seeds()
    else:
        print(__doc__)
