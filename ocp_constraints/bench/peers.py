"""Peers run side by side with ``ocp-constraints bench`` (optional; each skipped if missing).

- rockit (``rockit-meco``) and Drake's ``DirectCollocation`` (``drake``): the pendulum
  swing-up of ``problems/pendulum.py`` in its minimal coordinate, ``J_A psi'' = tau -
  m g L/2 sin psi`` with ``J_A = m L^2/3`` (m = 1, L = 1, g = 9.81 along -E2, torque
  about E3, |tau| <= 20, hanging at rest to upright at rest in 2 s, min int tau^2),
  each with its own transcription and IPOPT (tol 1e-10). Errors of the states at the
  mesh points against the same Pontryagin reference as ours.
- Pinocchio (``pin``): the tilted rod of the ``pendulum`` scene on a revolute joint,
  ABA integrated by SciPy's DOP853, and the joint load (force and moment at the hinge)
  from RNEA's transmitted spatial force ``data.f``.
- SymPy + SciPy: the sliding disk by ``sympy.physics.mechanics.LagrangesMethod`` with
  the contact as a holonomic constraint ``z - R sin(theta) = 0`` (its multiplier is the
  normal force), integrated by DOP853.

Times are wall times of building (problem construction / derivation) and solving.
"""
from __future__ import annotations

import importlib.util
import math
import time

import numpy as np

from ..scenes.registry import load_scene_module

IPOPT_TOL = 1e-10


def available(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def _pendulum_constants():
    p = load_scene_module("pendulum").DEFAULTS
    m, L, g = p["mass"], p["length"], p["gravity"]
    return m * L**2 / 3, m * g * L / 2, p["max_torque"]


def rockit_swing_up(N: int, degree: int = 3):
    """rockit: DirectCollocation(N, degree) (Radau points), piecewise-constant control."""
    import casadi as ca
    import rockit

    J, c, tmax = _pendulum_constants()
    started, cpu = time.perf_counter(), time.process_time()
    ocp = rockit.Ocp(T=2.0)
    psi, w = ocp.state(), ocp.state()
    u = ocp.control()
    ocp.set_der(psi, w)
    ocp.set_der(w, (u - c * ca.sin(psi)) / J)
    ocp.add_objective(ocp.integral(u**2))
    ocp.subject_to(-tmax <= (u <= tmax))
    ocp.subject_to(ocp.at_t0(psi) == 0)
    ocp.subject_to(ocp.at_t0(w) == 0)
    ocp.subject_to(ocp.at_tf(psi) == math.pi)
    ocp.subject_to(ocp.at_tf(w) == 0)
    ocp.set_initial(psi, math.pi * ocp.t / 2 - ca.sin(math.pi * ocp.t / 2))
    ocp.solver("ipopt", {"ipopt.tol": IPOPT_TOL, "ipopt.constr_viol_tol": IPOPT_TOL, "ipopt.print_level": 0,
                         "print_time": False, "record_time": True, "ipopt.sb": "yes"})
    ocp.method(rockit.DirectCollocation(N=N, degree=degree, scheme="radau"))
    built = time.perf_counter()
    sol = ocp.solve()
    solved, solved_cpu = time.perf_counter(), time.process_time()
    t, P = sol.sample(psi, grid="control")
    _, W = sol.sample(w, grid="control")
    st = sol.stats if hasattr(sol, "stats") else {}
    opti = ocp._method.opti
    return {"t": np.asarray(t), "psi": np.asarray(P), "psi_dot": np.asarray(W), "build_s": built - started,
            "solve_s": solved - built, "iterations": int(st.get("iter_count", -1)),
            "setting": f"rockit DirectCollocation(N={N}, degree={degree})",
            # IPOPT's own times (record_time), problem to solution in all, the NLP's size
            "objective": float(sol.value(ocp.objective)), "ipopt_wall_s": st.get("t_wall_total", np.nan),
            "ipopt_cpu_s": st.get("t_proc_total", np.nan), "total_s": solved - started,
            "total_cpu_s": solved_cpu - cpu, "size": (opti.nx, opti.ng)}


def drake_swing_up(N: int):
    """Drake: DirectCollocation (cubic Hermite states, first-order-hold input) with N intervals."""
    from pydrake.planning import DirectCollocation
    from pydrake.solvers import IpoptSolver, SolverOptions
    from pydrake.symbolic import Variable, sin
    from pydrake.systems.primitives import SymbolicVectorSystem
    from pydrake.trajectories import PiecewisePolynomial

    J, c, tmax = _pendulum_constants()
    started = time.perf_counter()
    x = [Variable("psi"), Variable("w")]
    u = Variable("tau")
    system = SymbolicVectorSystem(state=x, input=[u], dynamics=[x[1], (u - c * sin(x[0])) / J])
    context = system.CreateDefaultContext()
    h = 2.0 / N
    dircol = DirectCollocation(system, context, num_time_samples=N + 1, minimum_time_step=h, maximum_time_step=h)
    prog = dircol.prog()
    dircol.AddConstraintToAllKnotPoints(dircol.input()[0] <= tmax)
    dircol.AddConstraintToAllKnotPoints(-tmax <= dircol.input()[0])
    prog.AddBoundingBoxConstraint([0.0, 0.0], [0.0, 0.0], dircol.initial_state())
    prog.AddBoundingBoxConstraint([math.pi, 0.0], [math.pi, 0.0], dircol.final_state())
    dircol.AddRunningCost(dircol.input()[0] ** 2)
    ts = np.linspace(0, 2.0, N + 1)
    guess = np.vstack([math.pi * ts / 2 - np.sin(math.pi * ts / 2), math.pi / 2 * (1 - np.cos(math.pi * ts / 2))])
    dircol.SetInitialTrajectory(PiecewisePolynomial(), PiecewisePolynomial.FirstOrderHold(ts, guess))
    opts = SolverOptions()
    solver = IpoptSolver()
    opts.SetOption(solver.solver_id(), "tol", IPOPT_TOL)
    opts.SetOption(solver.solver_id(), "constr_viol_tol", IPOPT_TOL)
    opts.SetOption(solver.solver_id(), "print_level", 0)
    built = time.perf_counter()
    result = solver.Solve(prog, None, opts)
    solved = time.perf_counter()
    X = dircol.GetStateSamples(result)
    return {"t": np.asarray(dircol.GetSampleTimes(result)), "psi": X[0], "psi_dot": X[1], "build_s": built - started,
            "solve_s": solved - built, "iterations": -1, "success": result.is_success(),
            "setting": f"Drake DirectCollocation(N={N})"}


def pinocchio_pendulum(t_final: float, rtol: float, p: dict | None = None):
    """Pinocchio: the tilted rod on a revolute joint about E3; loads from RNEA's ``data.f``.
    ``p``: the scene's parameters (default its DEFAULTS)."""
    import pinocchio as pin
    from scipy.integrate import solve_ivp

    p = load_scene_module("pendulum").DEFAULTS if p is None else p
    m, L, g = p["mass"], p["length"], p["gravity"]
    tilt = math.radians(p["tilt_deg"])
    started = time.perf_counter()
    d = np.array([0.0, -math.cos(tilt), math.sin(tilt)])
    model = pin.Model()
    model.gravity.linear = np.array([0.0, -g, 0.0])
    jid = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "hinge")
    Ic = m * L**2 / 12 * (np.eye(3) - np.outer(d, d))
    model.appendBodyToJoint(jid, pin.Inertia(m, L / 2 * d, Ic), pin.SE3.Identity())
    data = model.createData()
    zero = np.zeros(1)

    def rhs(_, y):
        return [y[1], float(pin.aba(model, data, y[:1], y[1:], zero)[0])]

    built = time.perf_counter()
    ts = np.arange(0, t_final + 1e-9, 0.01)
    sol = solve_ivp(rhs, (0, t_final), [math.radians(p["angle0_deg"]), 0.0], method="DOP853", rtol=rtol, atol=rtol, t_eval=ts)
    F, M = [], []
    for k in range(len(ts)):
        q, v = sol.y[:1, k], sol.y[1:, k]
        a = pin.aba(model, data, q, v, zero)
        pin.rnea(model, data, q, v, a)
        pin.forwardKinematics(model, data, q)  # rnea leaves data.oMi untouched
        f = data.oMi[jid].act(data.f[jid])  # spatial force on the rod from the ground, about the world origin (= hinge)
        F.append(f.linear.copy())
        M.append(f.angular.copy())
    solved = time.perf_counter()
    F, M = np.array(F), np.array(M)
    return {"t": ts, "states": {"rod.psi": sol.y[0], "rod.psi_dot": sol.y[1]},
            "lambda": {"hinge.v1.lambda": F[:, 0], "hinge.v2.lambda": F[:, 1], "hinge.v3.lambda": F[:, 2],
                       "hinge.w1.lambda": M[:, 0], "hinge.w2.lambda": M[:, 1]},
            "build_s": built - started, "solve_s": solved - built, "setting": f"Pinocchio ABA+RNEA, DOP853 rtol={rtol:g}"}


def sympy_sliding_disk(t_final: float, rtol: float, p: dict | None = None):
    """sympy.physics.mechanics LagrangesMethod with the contact multiplier, lambdified, DOP853.
    ``p``: the scene's parameters (default its DEFAULTS)."""
    import sympy as sp
    from scipy.integrate import solve_ivp
    from sympy.physics import mechanics as me

    p = load_scene_module("sliding_disk").DEFAULTS if p is None else p
    m, R, g = p["mass"], p["radius"], p["gravity"]
    started = time.perf_counter()
    x, y, z, psi, th, ph = me.dynamicsymbols("x y z psi theta phi")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Body", [psi, th, ph], "313")
    O = me.Point("O")
    G = O.locatenew("G", x * N.x + y * N.y + z * N.z)
    G.set_vel(N, G.pos_from(O).dt(N))
    I = me.inertia(B, m * R**2 / 4, m * R**2 / 4, m * R**2 / 2)
    disk = me.RigidBody("disk", G, B, m, (I, G))
    disk.potential_energy = m * g * z
    Lag = me.Lagrangian(N, disk)
    qs = [x, y, z, psi, th, ph]
    lm = me.LagrangesMethod(Lag, qs, hol_coneqs=[z - R * sp.sin(th)], frame=N)
    lm.form_lagranges_equations()
    qd = [sp.diff(q) for q in qs]
    lam = lm.lam_vec
    states = qs + qd
    subs = {s: sp.Symbol(f"s{i}") for i, s in enumerate(reversed(qd))}
    syms = [sp.Symbol(f"q{i}") for i in range(6)] + [sp.Symbol(f"v{i}") for i in range(6)]
    rep = dict(zip(reversed(qd), reversed(syms[6:])))
    rep.update(dict(zip(qs, syms[:6])))
    Mf = sp.lambdify(syms, lm.mass_matrix_full.xreplace(rep), "numpy")
    ff = sp.lambdify(syms, lm.forcing_full.xreplace(rep), "numpy")
    del subs, states
    built = time.perf_counter()

    def solve_all(yv):
        return np.linalg.solve(np.asarray(Mf(*yv), float), np.asarray(ff(*yv), float).ravel())

    def rhs(_, yv):
        return solve_all(yv)[:12]

    th0, thd0 = p["theta0"], p["theta_dot0"]
    y0 = [0, 0, R * math.sin(th0), 0, th0, 0, p["x_dot0"], p["y_dot0"], R * math.cos(th0) * thd0, p["psi_dot0"], thd0, p["phi_dot0"]]
    ts = np.arange(0, t_final + 1e-9, 0.01)
    sol = solve_ivp(rhs, (0, t_final), y0, method="DOP853", rtol=rtol, atol=rtol, t_eval=ts)
    lam_n = np.array([solve_all(sol.y[:, k])[12] for k in range(len(ts))])
    solved = time.perf_counter()
    names = ["disk.x", "disk.y", "disk.z", "disk.psi", "disk.theta", "disk.phi"]
    return {"t": ts, "states": dict(zip(names, sol.y[:6])), "lambda": {"contact.n.lambda": lam_n},
            "build_s": built - started, "solve_s": solved - built, "setting": f"sympy LagrangesMethod + DOP853 rtol={rtol:g}",
            "n_lambda": len(lam)}
