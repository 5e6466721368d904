"""References for the tracking rod, WITHOUT the library: plain CasADi + NumPy.

Rod (mass M, length L) pinned at one end, angle psi from hanging down, motor torque tau about the pin:
    I_A psi'' = tau - M g (L/2) sin psi,   I_A = M L^2 / 3
    min  int_0^T  W (psi - r(t))^2 + tau^2  dt,   psi(0) = psi'(0) = 0, final state free.

Radau IIA collocation of degree 7 (coefficients from tests/newcomer_reference.py) on a mesh ALIGNED with the
50 Hz sample times (every 0.02 s a mesh point, each sample interval cut in `sub` pieces), so a piecewise-linear
or a cubic-spline reference is smooth inside every interval (for W >= 1e6 the first 0.1 s 8x finer). IPOPT tol 1e-12. Run at sub = 1 and 2 to show
its own accuracy (`python nc9.py ref NAME`).

The hinge force on the rod is Newton-Euler, F = M (a_G - g), with G = (L/2)(sin psi, -cos psi).
"""
from __future__ import annotations

import sys
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from newcomer_reference import radau_coefficients  # noqa: E402  (Radau IIA nodes, derivative matrix, weights)

M, L, G, T, W = 1.0, 1.0, 9.81, 2.0, 1000.0
I_A = M * L**2 / 3
DEG = 7
DT_SAMPLE = 0.02


def solve(r_num, sub: int = 1, deg: int = DEG, W: float = W) -> dict:
    """r_num: numpy reference r(t). Returns mesh, nodes, states (psi, w) at 0+tau nodes, torque at tau nodes."""
    n_samples = int(round(T / DT_SAMPLE))
    mesh = np.linspace(0.0, T, n_samples * sub + 1)
    if W >= 1e6:    # tight tracking: the start (psi(0) = 0 against r(0) = 0.2) is a boundary layer of ~10 ms;
        # the first 0.1 s (5 sample intervals) graded 8x finer, sample times kept as mesh points
        head = np.linspace(0.0, 5 * DT_SAMPLE, 5 * sub * 8 + 1)
        mesh = np.unique(np.concatenate([head, mesh[mesh > 5 * DT_SAMPLE + 1e-12]]))
    N = mesh.size - 1
    tau, C, B = radau_coefficients(deg)
    opti = ca.Opti()
    X = opti.variable(2, N * deg + 1)        # state at mesh start + deg collocation points per interval
    U = opti.variable(1, N * deg)            # torque at collocation points
    J = 0
    opti.subject_to(X[:, 0] == ca.DM([0.0, 0.0]))
    guess_psi = []
    for k in range(N):
        h = mesh[k + 1] - mesh[k]
        cols = [k * deg + j for j in range(deg + 1)]      # node 0 = interval start (= previous end)
        Xk = X[:, cols]
        for r in range(1, deg + 1):
            xp = sum(C[j, r] * Xk[:, j] for j in range(deg + 1)) / h
            psi, w = Xk[0, r], Xk[1, r]
            u = U[0, k * deg + r - 1]
            opti.subject_to(xp[0] == w)
            opti.subject_to(xp[1] == (u - M * G * L / 2 * ca.sin(psi)) / I_A)
            tr = mesh[k] + tau[r - 1] * h
            J += h * B[r] * (W * (psi - r_num(tr)) ** 2 + u**2)
    opti.minimize(J)
    t_nodes = np.concatenate([[0.0]] + [mesh[k] + tau * (mesh[k + 1] - mesh[k]) for k in range(N)])
    opti.set_initial(X[0, :], r_num(t_nodes).reshape(1, -1))
    opti.solver("ipopt", {"print_time": False}, {"tol": 1e-12, "print_level": 0, "max_iter": 500,
                                                  "linear_solver": "mumps"})
    s = opti.solve()
    return dict(mesh=mesh, tau=tau, deg=deg, X=np.array(s.value(X)), U=np.array(s.value(U)).reshape(-1),
                J=float(s.value(J)))


def _lagrange(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Lagrange basis of `nodes` at `x`: len(x) x len(nodes)."""
    Lm = np.ones((x.size, nodes.size))
    for j in range(nodes.size):
        for m in range(nodes.size):
            if m != j:
                Lm[:, j] *= (x - nodes[m]) / (nodes[j] - nodes[m])
    return Lm


def evaluate(ref: dict, t: np.ndarray) -> dict:
    """psi, w, tau at times t through each interval's polynomials (states degree 7, torque degree 6 through
    the collocation points), and the hinge force (world x, y) by Newton-Euler."""
    t = np.atleast_1d(np.asarray(t, float))
    mesh, tau, deg, X, U = ref["mesh"], ref["tau"], ref["deg"], ref["X"], ref["U"]
    k = np.clip(np.searchsorted(mesh, t, side="right") - 1, 0, mesh.size - 2)
    out = {n: np.zeros(t.size) for n in ("psi", "w", "tau")}
    nodes = np.r_[0.0, tau]
    for kk in np.unique(k):
        sel = k == kk
        h = mesh[kk + 1] - mesh[kk]
        s = (t[sel] - mesh[kk]) / h
        Ls = _lagrange(nodes, s)
        cols = [kk * deg + j for j in range(deg + 1)]
        out["psi"][sel] = Ls @ X[0, cols]
        out["w"][sel] = Ls @ X[1, cols]
        out["tau"][sel] = _lagrange(tau, s) @ U[kk * deg: (kk + 1) * deg]
    psi, w, u = out["psi"], out["w"], out["tau"]
    wd = (u - M * G * L / 2 * np.sin(psi)) / I_A
    a = (L / 2) * np.stack([wd * np.cos(psi) - w**2 * np.sin(psi), wd * np.sin(psi) + w**2 * np.cos(psi)])
    out["wdot"] = wd
    out["Fx"] = M * a[0]
    out["Fy"] = M * (a[1] + G)
    return out
