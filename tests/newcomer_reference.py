"""Independent references for user-written optimal-control problems (issue 13, "problems not in the suite").

Minimal coordinates and Lagrange's equations, derived here from the kinetic and potential energy of
the bodies (no constraint, no multiplier, nothing of ``ocp_constraints``), transcribed with plain
CasADi Opti by Legendre-Gauss-Radau collocation of degree 3 (states at the mesh and collocation
points, inputs at the collocation points, the objective by the Radau quadrature) and solved by IPOPT.
Constraint loads are recomputed from the solution by Newton-Euler on a body (``a_cm`` from the
generalized coordinates), again without the library.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import casadi as ca
import numpy as np


def rot3(a):
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def rot2(a):
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot1(a):
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


@dataclass
class RigidBody:
    """A body in minimal coordinates: mass (kg), inertia about the center of mass (body basis, kg m^2),
    center of mass ``x(q)`` (m, fixed basis) and rotation ``R(q)`` (body basis in the fixed basis)."""

    mass: float
    inertia: np.ndarray
    x: ca.SX
    R: ca.SX


@dataclass
class LagrangeSystem:
    """``d/dt dT/dqd - dT/dq + dV/dq = Q(q, qd, w)`` for a list of rigid bodies; ``Q`` from fixed-basis
    torques on bodies and forces at points, as functions of the inputs ``w``."""

    q: ca.SX
    w: ca.SX
    bodies: list[RigidBody]
    gravity: np.ndarray
    generalized_force: ca.SX = None
    qd: ca.SX = field(init=False)

    def __post_init__(self):
        n = self.q.numel()
        self.qd = ca.SX.sym("qd", n)
        T, V = 0, 0
        self.v, self.omega = [], []
        for b in self.bodies:
            v = ca.jtimes(b.x, self.q, self.qd)
            Rdot = ca.jtimes(b.R, self.q, self.qd)
            W = Rdot @ b.R.T
            om = ca.vertcat(W[2, 1], W[0, 2], W[1, 0])
            self.v.append(v)
            self.omega.append(om)
            T += 0.5 * b.mass * ca.dot(v, v) + 0.5 * ca.dot(om, b.R @ ca.DM(b.inertia) @ b.R.T @ om)
            V -= b.mass * ca.dot(ca.DM(self.gravity), b.x)
        Qg = ca.SX.zeros(n) if self.generalized_force is None else self.generalized_force
        M = ca.hessian(T, self.qd)[0]
        dTdqd = ca.gradient(T, self.qd)
        rhs = Qg + ca.gradient(T, self.q) - ca.gradient(V, self.q) - ca.jtimes(dTdqd, self.q, self.qd)
        self.qdd = ca.solve(M, rhs)
        self.T, self.V = T, V

    def torque_work(self, body: int, torque: ca.SX) -> ca.SX:
        """Generalized force of a fixed-basis torque on body ``body``: ``(d omega/d qd)^T tau``."""
        return ca.jacobian(self.omega[body], self.qd).T @ torque

    def force_work(self, point: ca.SX, force: ca.SX) -> ca.SX:
        """Generalized force of a fixed-basis force at the point ``point(q)``."""
        return ca.jacobian(point, self.q).T @ force


def radau_coefficients(degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Radau IIA on [0, 1] from the Lagrange polynomials of the nodes 0, tau_1..tau_degree: the collocation
    points ``tau``, the derivative matrix ``C[j, r]`` (polynomial j's slope at node r) and the weights ``B[j]``."""
    tau = np.array(ca.collocation_points(degree, "radau"))
    nodes = np.r_[0.0, tau]
    C = np.zeros((degree + 1, degree + 1))
    B = np.zeros(degree + 1)
    for j in range(degree + 1):
        p = np.poly1d([1.0])
        for r in range(degree + 1):
            if r != j:
                p *= np.poly1d([1.0, -nodes[r]]) / (nodes[j] - nodes[r])
        dp = np.polyder(p)
        for r in range(degree + 1):
            C[j, r] = dp(nodes[r])
        B[j] = np.polyint(p)(1.0)
    return tau, C, B


def radau_solve(system: LagrangeSystem, N: int, t_final, lagrangian: ca.SX, initial: dict, final: dict,
                input_bounds=None, path: list | None = None, guess_q: Callable | None = None,
                free_time: tuple | None = None, time_weight: float = 0.0, degree: int = 3,
                start: tuple | None = None, mesh: np.ndarray | None = None) -> dict:
    """Radau-``degree`` collocation on ``N`` uniform intervals of ``x = (q, qd)``, ``x' = (qd, qdd)``, or on
    ``mesh`` (``N + 1`` fractions of the horizon from 0 to 1: put the mesh points at known junctions).

    ``initial``/``final``: index -> value over ``x``; ``path``: ``(expression of q, qd, qdd, w, lower, upper)``;
    ``free_time``: ``(lower, upper)`` with ``t_final`` the guess; ``start``: ``(X, W)`` a full guess at
    the points (states ``2n x (N degree + 1)``, inputs ``m x N degree``). Returns the objective, iterations and samples.
    """
    n, m = system.q.numel(), system.w.numel()
    x = ca.vertcat(system.q, system.qd)
    f = ca.Function("f", [x, system.w], [ca.vertcat(system.qd, system.qdd), lagrangian, system.qdd])
    tau, C, B = radau_coefficients(degree)
    opti = ca.Opti()
    T = opti.variable() if free_time else t_final
    if free_time:
        opti.subject_to(opti.bounded(free_time[0], T, free_time[1]))
        opti.set_initial(T, t_final)
    mesh = np.linspace(0.0, 1.0, N + 1) if mesh is None else np.asarray(mesh, float)
    if mesh.shape != (N + 1,) or mesh[0] != 0.0 or mesh[-1] != 1.0 or np.any(np.diff(mesh) <= 0):
        raise ValueError(f"mesh: {N + 1} increasing fractions from 0 to 1 expected")
    X = opti.variable(2 * n, N * degree + 1)
    Wv = opti.variable(m, N * degree) if m else None
    J = time_weight * T if free_time else 0
    path_fn = None
    if path:
        path_fn = ca.Function("path", [x, system.w], [ca.vertcat(*[p[0] for p in path])])
        plo, pup = np.array([p[1] for p in path]), np.array([p[2] for p in path])
    for k in range(N):
        h = T * (mesh[k + 1] - mesh[k])
        cols = [X[:, k * degree + j] for j in range(degree + 1)]
        for j in range(1, degree + 1):
            xp = sum(C[r, j] * cols[r] for r in range(degree + 1))
            wk = Wv[:, k * degree + j - 1] if m else ca.DM.zeros(0)
            dx, L, _ = f(cols[j], wk)
            opti.subject_to(xp == h * dx)
            J += h * B[j] * L
            if path_fn is not None:
                g = path_fn(cols[j], wk)
                for i in range(len(path)):
                    opti.subject_to(opti.bounded(plo[i], g[i], pup[i]))
            if input_bounds is not None and m:
                opti.subject_to(opti.bounded(input_bounds[0], wk, input_bounds[1]))
    for i, v in initial.items():
        opti.subject_to(X[i, 0] == v)
    for i, v in final.items():
        opti.subject_to(X[i, -1] == v)
    if guess_q is not None:
        s = np.linspace(0.0, 1.0, N * degree + 1)
        opti.set_initial(X[:n, :], np.atleast_2d(guess_q(s)))
    if start is not None:
        opti.set_initial(X, start[0])
        if m:
            opti.set_initial(Wv, start[1])
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-10})
    sol = opti.solve()
    Tf = float(sol.value(T)) if free_time else float(t_final)
    t = np.concatenate([[0.0], (mesh[:-1, None] + np.diff(mesh)[:, None] * tau[None, :]).ravel()]) * Tf
    Xs = np.atleast_2d(sol.value(X))
    Ws = np.atleast_2d(sol.value(Wv)) if m else np.zeros((0, N * degree))
    return {"objective": float(sol.value(J)), "iterations": int(sol.stats()["iter_count"]), "t": t, "X": Xs,
            "W": Ws, "t_final": Tf, "f": f}


def arm_least_time_shooting(seed_times, shoulder_first: float = 6.0, elbow_first: float = -2.0) -> np.ndarray:
    """The URDF arm's least-time motion as bang-bang torques by shooting, independent of the library: Lagrange's
    equations from the energies (tests/newcomer_reference.py; links 0.5 m / 1 kg and 0.4 m / 0.8 kg, slender rods,
    gravity -9.81 along y), the elbow motor's reaction on link 1; the shoulder at ``shoulder_first`` N m then its
    opposite, the elbow at ``elbow_first``, its opposite, ``elbow_first`` again (two local optima are known: +6 / -2,
    the joint-coordinate refinement's, and +6 / +2, 1.75e-4 s shorter, the maximal one's); unknowns (elbow switch 1,
    shoulder switch, elbow switch 2, T) by Newton on the end state, DOP853 at rtol 1e-12. The arc structure is read
    off the library's solution (``seed_times`` and the signs): an assumption, as the swing-up's.
    Returns the four times (s); used by tests/test_mesh_refinement_switches.py and scripts/bang_bang_jumps.py."""
    from scipy.integrate import solve_ivp

    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 2)
    e = lambda a: ca.vertcat(ca.cos(a), ca.sin(a), 0)       # noqa: E731
    rod = lambda m, L: np.diag([1e-4, m * L**2 / 12, m * L**2 / 12])       # noqa: E731
    bodies = [RigidBody(1.0, rod(1.0, 0.5), 0.25 * e(q[0]), rot3(q[0])),
              RigidBody(0.8, rod(0.8, 0.4), 0.5 * e(q[0]) + 0.2 * e(q[0] + q[1]), rot3(q[0] + q[1]))]
    s0 = LagrangeSystem(q, w, bodies, np.array([0.0, -9.81, 0.0]))
    z = lambda v: ca.vertcat(0, 0, v)       # noqa: E731
    Q = s0.torque_work(0, z(w[0])) + s0.torque_work(1, z(w[1])) - s0.torque_work(0, z(w[1]))
    s = LagrangeSystem(q, w, bodies, np.array([0.0, -9.81, 0.0]), Q)
    f = ca.Function("f", [ca.vertcat(q, s.qd), w], [ca.vertcat(s.qd, s.qdd)])

    def end(x):
        te1, ts, te2, T = x
        cuts = sorted({0.0, te1, ts, te2, T})
        y = np.array([-np.pi / 2, 0.0, 0.0, 0.0])
        for a, b in zip(cuts[:-1], cuts[1:]):
            m = 0.5 * (a + b)
            tau = [shoulder_first if m < ts else -shoulder_first, elbow_first if m < te1 or m > te2 else -elbow_first]
            y = solve_ivp(lambda t, y: np.asarray(f(y, tau)).ravel(), (a, b), y, method="DOP853", rtol=1e-12,
                          atol=1e-12).y[:, -1]
        return y - np.array([-np.pi / 4, np.pi / 4, 0.0, 0.0])

    x = np.array(seed_times, float)
    for _ in range(20):     # at least one Newton step: seeds already within the end tolerance are moved by it too
        J = np.column_stack([(end(x + d) - end(x - d)) / 2e-7 for d in np.eye(4) * 1e-7])
        step = np.linalg.solve(J, end(x))
        x = x - step
        if np.abs(step).max() < 1e-13:
            break
    assert np.abs(end(x)).max() < 1e-10
    return x
