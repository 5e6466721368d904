"""Independent references for the benchmarks: each computed by a different method.

- :func:`swing_up_reference`: the pendulum swing-up optimum from Pontryagin's
  conditions (1 degree of freedom, ``J_A psi'' = tau - c sin psi``), solved by shooting on
  the two initial costates with SciPy's DOP853 at ``rtol = 1e-13``; hinge loads from the
  Newton-Euler balance of the rod written out by hand. No collocation, no library code.
- :func:`pendulum_reference`: the tilted pendulum released from rest, the same hand
  balance (``m L^2/3 cos^2(tilt) psi'' = -m g L/2 cos(tilt) sin psi``), DOP853.
- :func:`sliding_cylinder_reference`: the exact motion (uniform sliding and spin) and
  the paper's eq. (18) for the loads.
- :func:`sliding_disk_lambda_eq4`: the paper's eq. (4) on a given motion.
- :func:`integrator_reference`: for scenes without a closed form, DOP853 at
  ``rtol = 1e-13`` on the library's own KKT equations. This checks the integrator and
  the settings only, not the equations (the test suite checks those against
  Lagrange's equations); the bench labels it so.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_bvp, solve_ivp

from ..ocp.schemes import Radau
from ..ocp.switch_detection import detect_switches
from ..scenes.registry import build_scene, load_scene_module

RTOL = 1e-13
#: The tightest tolerance SciPy's DOP853 accepts (100 machine epsilons); the forward duel's
#: references, whose peers reach ~1e-11 (at RTOL the sliding disk's omega is good to only 2e-10).
TIGHTEST_RTOL = 2.3e-14


# -- pendulum swing-up (optimal control) ------------------------------------------------------
class SwingUpReference:
    """Pontryagin extremal of ``min int tau^2`` for the planar rod; call with times."""

    def __init__(self, p: dict[str, float], t_final: float = 2.0):
        m, L, g = p["mass"], p["length"], p["gravity"]
        self.m, self.L, self.g, self.T = m, L, g, t_final
        self.J = m * L**2 / 3
        self.c = m * g * L / 2
        self.max_torque = p["max_torque"]
        p0 = self._costates_by_collocation()
        self.p0 = self._shoot(p0)
        self.sol = self._integrate(self.p0)
        tau = self.torque(np.linspace(0, t_final, 2001))
        if np.abs(tau).max() > self.max_torque:
            raise RuntimeError("the unconstrained extremal exceeds the torque bound: the reference does not apply")
        self.objective = solve_ivp(lambda t, y: [self.torque(np.array([t]))[0] ** 2], (0, t_final), [0.0],
                                   method="DOP853", rtol=RTOL, atol=RTOL).y[0, -1]

    def _rhs(self, t, y):
        psi, w, p1, p2 = y
        tau = -p2 / (2 * self.J)
        return [w, (tau - self.c * np.sin(psi)) / self.J, p2 * self.c * np.cos(psi) / self.J, -p1]

    def _costates_by_collocation(self) -> np.ndarray:
        """A starting point for shooting: SciPy's collocation BVP solver, from a swing-back guess."""
        t = np.linspace(0, self.T, 101)
        s = math.pi * t / self.T
        y = np.vstack([math.pi * t / self.T - np.sin(s), math.pi / self.T * (1 - np.cos(s)), np.zeros_like(t), np.zeros_like(t)])

        def bc(ya, yb):
            return np.array([ya[0], ya[1], yb[0] - math.pi, yb[1]])

        res = solve_bvp(lambda t, y: np.array(self._rhs(t, y)), bc, t, y, tol=1e-6, max_nodes=100000)
        return res.sol(0.0)[2:]

    def _integrate(self, p0):
        return solve_ivp(self._rhs, (0, self.T), [0.0, 0.0, *p0], method="DOP853", rtol=RTOL, atol=RTOL, dense_output=True)

    def _shoot(self, p0: np.ndarray) -> np.ndarray:
        p = np.asarray(p0, float)
        for _ in range(30):
            r = self._end(p)
            if np.abs(r).max() < 1e-12:
                return p
            Jac = np.zeros((2, 2))
            for k in range(2):
                dp = np.zeros(2)
                dp[k] = 1e-7 * max(1.0, abs(p[k]))
                Jac[:, k] = (self._end(p + dp) - self._end(p - dp)) / (2 * dp[k])
            p = p - np.linalg.solve(Jac, r)
        if np.abs(self._end(p)).max() > 1e-10:
            raise RuntimeError(f"shooting for the swing-up reference did not converge: end residual {self._end(p)}")
        return p

    def _end(self, p) -> np.ndarray:
        y = self._integrate(p).y[:, -1]
        return np.array([y[0] - math.pi, y[1]])

    def states(self, t) -> tuple[np.ndarray, np.ndarray]:
        y = self.sol.sol(np.asarray(t, float))
        return y[0], y[1]

    def torque(self, t) -> np.ndarray:
        return -self.sol.sol(np.asarray(t, float))[3] / (2 * self.J)

    def multipliers(self, t) -> dict[str, np.ndarray]:
        """Hinge loads on the rod: ``F = m r'' - m g_vec`` at the hinge, no moments (planar rod)."""
        psi, w = self.states(t)
        acc = (self.torque(t) - self.c * np.sin(psi)) / self.J
        h = self.L / 2
        ax = h * (acc * np.cos(psi) - w**2 * np.sin(psi))
        ay = h * (acc * np.sin(psi) + w**2 * np.cos(psi))
        zero = np.zeros_like(psi)
        return {"hinge.v1.lambda": self.m * ax, "hinge.v2.lambda": self.m * ay + self.m * self.g,
                "hinge.v3.lambda": zero, "hinge.w1.lambda": zero, "hinge.w2.lambda": zero}


def swing_up_reference(overrides: dict | None = None) -> SwingUpReference:
    module = load_scene_module("pendulum")
    return SwingUpReference({**module.DEFAULTS, **(overrides or {})})


# -- forward simulations ------------------------------------------------------------------------
def pendulum_reference(p: dict[str, float], t: np.ndarray, rtol: float = RTOL) -> dict[str, np.ndarray]:
    """The tilted rod released from rest at ``angle0`` about E3 (scene ``pendulum``); DOP853 at ``rtol``."""
    m, L, g = p["mass"], p["length"], p["gravity"]
    tilt = math.radians(p["tilt_deg"])
    ct, st = math.cos(tilt), math.sin(tilt)
    J3 = m * L**2 / 3 * ct**2

    def rhs(_, y):
        return [y[1], -m * g * L / 2 * ct * math.sin(y[0]) / J3]

    sol = solve_ivp(rhs, (t[0], t[-1]), [math.radians(p["angle0_deg"]), 0.0], method="DOP853", rtol=rtol, atol=rtol,
                    t_eval=t)
    psi, w = sol.y
    acc = -m * g * L / 2 * ct * np.sin(psi) / J3
    h = L / 2
    # r = h (ct sin psi, -ct cos psi, st); F = m r'' - m g_vec with g_vec = (0, -g, 0).
    F = np.array([m * h * ct * (acc * np.cos(psi) - w**2 * np.sin(psi)),
                  m * h * ct * (acc * np.sin(psi) + w**2 * np.cos(psi)) + m * g, np.zeros_like(psi)])
    # Moment about the hinge: M_c = dH_A/dt - r x (m g_vec); H_A = Q J_A Q^T omega, omega = psi' E3.
    d = np.array([0.0, -ct, st])
    JA = m * L**2 / 3 * (np.eye(3) - np.outer(d, d))
    M = np.zeros((3, len(t)))
    for k in range(len(t)):
        c, s = math.cos(psi[k]), math.sin(psi[k])
        Q = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        I = Q @ JA @ Q.T
        om = np.array([0, 0, w[k]])
        r = h * Q @ d
        M[:, k] = np.cross(om, I @ om) + I @ np.array([0, 0, acc[k]]) - np.cross(r, [0, -m * g, 0])
    return {"states": {"rod.psi": psi, "rod.psi_dot": w},
            "lambda": {"hinge.v1.lambda": F[0], "hinge.v2.lambda": F[1], "hinge.v3.lambda": F[2],
                       "hinge.w1.lambda": M[0], "hinge.w2.lambda": M[1]},
            "method": f"hand-written 1-DOF balance, DOP853 rtol {rtol:g}"}


def sliding_cylinder_reference(p: dict[str, float], t: np.ndarray) -> dict[str, np.ndarray]:
    """Exact: ``xbar`` moves uniformly, psi' and phi' are constant; loads by eq. (18).

    ``lambda_1 = m g``; ``M_c = lambda_2 (e3 x E3) = I_a psi' phi' (cos phi e1 - sin phi e2)``
    (eq. 18) and at theta = pi/2 ``e3 x E3 = -(cos phi e1 - sin phi e2)``, so
    ``lambda_2 = -I_a psi' phi'``.
    """
    m, r, g = p["mass"], p["radius"], p["gravity"]
    Ia = m * r**2 / 2
    ones = np.ones_like(t)
    states = {"cylinder.x": p["x0"] + p["x_dot0"] * t, "cylinder.y": p["y0"] + p["y_dot0"] * t,
              "cylinder.z": 0 * t, "cylinder.psi": p["psi0"] + p["psi_dot0"] * t,
              "cylinder.theta": math.pi / 2 * ones, "cylinder.phi": p["phi0"] + p["phi_dot0"] * t}
    return {"states": states,
            "lambda": {"plane.normal.lambda": m * g * ones, "plane.tilt.lambda": -Ia * p["psi_dot0"] * p["phi_dot0"] * ones},
            "method": "exact motion and paper eq. (18)"}


def sliding_disk_lambda_eq4(p: dict[str, float], theta, theta_dot, theta_ddot) -> np.ndarray:
    """Paper eq. (4): ``lambda = d/dt(m R theta' cos theta) + m g``."""
    m, R, g = p["mass"], p["radius"], p["gravity"]
    return m * R * (theta_ddot * np.cos(theta) - theta_dot**2 * np.sin(theta)) + m * g


def integrator_reference(scene_name: str, t: np.ndarray, overrides: dict | None = None, rtol: float = RTOL) -> dict:
    """DOP853 (``rtol``, default 1e-13) on the library's KKT equations: an integrator-only reference."""
    from ..mechanics.equations import SystemEquations
    from ..mechanics.state import consistent_state

    scene = build_scene(scene_name, overrides)
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    fd, qd = eqs.forward_dynamics, eqs.coordinate_rates
    nq, n_in = eqs.nq, eqs.inputs.numel()
    w0 = np.zeros(n_in)

    def rhs(ti, y):
        q, u = y[:nq], y[nq:]
        udot, _ = fd(q, u, ti, w0, w0)
        return np.concatenate([np.asarray(qd(q, u)).ravel(), np.asarray(udot).ravel()])

    sol = solve_ivp(rhs, (t[0], t[-1]), np.concatenate([q0, u0]), method="DOP853", rtol=rtol, atol=rtol, t_eval=t)
    Y = sol.y
    names = scene.model.coordinate_names + scene.model.speed_names
    lam = np.array([np.asarray(fd(Y[:nq, k], Y[nq:, k], t[k], w0, w0)[1]).ravel() for k in range(len(t))])
    out = {"states": {n: Y[i] for i, n in enumerate(names)},
           "lambda": {f"{c}.lambda": lam[:, k] for k, c in enumerate(eqs.constraint_names)},
           "method": f"integrator only: DOP853 rtol {rtol:g} on the library's equations"}
    if scene_name == "sliding_disk":
        # lambda by eq. (4) from the reference motion; theta'' = d/dt (g^2 . omega) by jtimes.
        import casadi as ca

        udot_sym = ca.SX.sym("udot", eqs.nu)
        qdd = ca.jtimes(eqs.qdot, eqs.q, eqs.qdot) + ca.jtimes(eqs.qdot, eqs.u, udot_sym)
        f = ca.Function("qdd", [eqs.q, eqs.u, udot_sym], [eqs.qdot, qdd])
        rates, accs = [], []
        for k in range(len(t)):
            udot = np.asarray(fd(Y[:nq, k], Y[nq:, k], t[k], w0, w0)[0]).ravel()
            r, a = f(Y[:nq, k], Y[nq:, k], udot)
            rates.append(float(r[4]))
            accs.append(float(a[4]))
        th = out["states"]["disk.theta"]
        out["lambda"] = {"contact.n.lambda": sliding_disk_lambda_eq4(scene.model.parameters, th, np.array(rates), np.array(accs))}
        out["method"] = f"states: DOP853 rtol {rtol:g} on the library's equations; lambda: paper eq. (4)"
    return out


def junction_mesh_solution(make, locate, intervals: int = 100, degree: int = 7):
    """A fine collocation solution whose mesh has a point at every switch of ``locate`` (a solution of the same problem,
    e.g. a refined one): uniform ``intervals`` plus those switch times, Radau ``degree``, started from ``locate``, IPOPT's
    complementarity held to 1e-13. At a junction (a friction cone becoming active) a uniform mesh's multipliers converge
    only like h (the rolling-disk drive: Radau 3 on 400 and 800 intervals 6.7e-5 apart); with the junctions as mesh
    points Radau 7 on 50 and 100 intervals agree to 1.4e-5 in the multipliers and 5e-7 in the states."""
    switches = sorted({round(w.fraction, 12) for w in detect_switches(locate) if w.inside})
    mesh = np.unique(np.r_[np.linspace(0.0, 1.0, intervals + 1), switches])
    return make().solve(Radau(mesh=tuple(mesh), degrees=(degree,) * (len(mesh) - 1)), {"ipopt.compl_inf_tol": 1e-13},
                        warm_start=locate)
