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
    started = time.perf_counter()
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
                         "print_time": False, "ipopt.sb": "yes"})
    ocp.method(rockit.DirectCollocation(N=N, degree=degree, scheme="radau"))
    built = time.perf_counter()
    sol = ocp.solve()
    solved = time.perf_counter()
    t, P = sol.sample(psi, grid="control")
    _, W = sol.sample(w, grid="control")
    it = int(sol.stats.get("iter_count", -1)) if hasattr(sol, "stats") else -1
    return {"t": np.asarray(t), "psi": np.asarray(P), "psi_dot": np.asarray(W), "build_s": built - started,
            "solve_s": solved - built, "iterations": it, "setting": f"rockit DirectCollocation(N={N}, degree={degree})"}


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


# -- forward simulation side by side (issue 14): interleaved runs, medians ----------------------
_OURS_SNIPPET = """
import time, sys
t = time.perf_counter()
from ocp_constraints import SystemEquations, build_scene, consistent_state, simulate
from ocp_constraints.dynamics.simulate import SimulationOptions
s = build_scene({scene!r}); e = SystemEquations(s.model); q0, u0 = consistent_state(e, s.coordinates, s.rates)
simulate(e, q0, u0, {t_final!r}, SimulationOptions(rtol={tol!r}, atol={tol!r}, compiled={compiled!r}))
"""
_PEER_SNIPPET = """import math, time
import numpy as np
{source}
{fn}({t_final!r}, {tol!r}, {p!r})
"""   # the peer's own code only: no import of this package in the peer's whole-process time


def _ours_once(scene_name: str, t_final: float, tol: float, compiled: str):
    from ..dynamics.simulate import SimulationOptions, simulate
    from ..mechanics.equations import SystemEquations
    from ..mechanics.state import consistent_state
    from ..scenes.registry import build_scene

    started = time.perf_counter()
    scene = build_scene(scene_name)
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, t_final, SimulationOptions(rtol=tol, atol=tol, compiled=compiled))
    return time.perf_counter() - started, traj


def _whole_process(code: str) -> float:
    import subprocess
    import sys

    started = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    return time.perf_counter() - started


def forward_duel(scene: str = "pendulum", t_final: float = 10.0, runs: int = 3,
                 ours=(1e-6, 1e-8, 1e-10, 1e-12, 1e-13, 1e-14), theirs=(1e-6, 1e-8, 1e-10, 1e-12),
                 whole_process: bool = True, log=print) -> dict:
    """Our forward simulation against the scene's peer (Pinocchio + DOP853 on ``pendulum``, sympy +
    DOP853 on ``sliding_disk``), every setting run ``runs`` times interleaved (ours, then theirs, then
    ours again ...) so that the machine's load falls on both alike; medians. In-process times: model
    built, consistent start, simulation (ours); model built, DOP853, loads (theirs). Whole-process
    times: a fresh Python running the same, imports included. Errors: max(state error, multiplier
    error / load scale) against the independent reference (:mod:`.references`)."""
    import inspect
    import os
    import statistics

    from .references import integrator_reference, pendulum_reference

    fn = {"pendulum": pinocchio_pendulum, "sliding_disk": sympy_sliding_disk}[scene]
    variants = [(tol, c) for tol in ours for c in ("never", "always")]
    _ours_once(scene, 0.05, 1e-8, "always")      # compiled libraries built once (not timed: "after the first load")
    times: dict = {}
    errors: dict = {}

    def error_of(t, states, lams):
        p = load_scene_module(scene).DEFAULTS
        rf = pendulum_reference(p, t) if scene == "pendulum" else integrator_reference(scene, t)
        scale = max(float(np.abs(v).max()) for v in rf["lambda"].values())
        st = max(float(np.abs(states[k] - rf["states"][k]).max()) for k in rf["states"] if k in states)
        return max(st, max(float(np.abs(lams[k] - rf["lambda"][k]).max()) for k in rf["lambda"]) / scale)

    env_note = f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    for rep in range(runs):
        for tol, c in variants:
            dt, traj = _ours_once(scene, t_final, tol, c)
            times.setdefault(("ours", tol, c, "in"), []).append(dt)
            if rep == 0:
                cols = traj.sample_columns()
                errors[("ours", tol, c)] = error_of(traj.t, cols, cols)
            if whole_process:
                code = _OURS_SNIPPET.format(scene=scene, t_final=t_final, tol=tol, compiled=c)
                times.setdefault(("ours", tol, c, "whole"), []).append(_whole_process(code))
        for tol in theirs:
            r = fn(t_final, tol)
            times.setdefault(("peer", tol, "", "in"), []).append(r["build_s"] + r["solve_s"])
            if rep == 0:
                errors[("peer", tol, "")] = error_of(r["t"], r["states"], r["lambda"])
            if whole_process:
                code = _PEER_SNIPPET.format(source=inspect.getsource(fn), fn=fn.__name__, t_final=t_final, tol=tol,
                                            p=dict(load_scene_module(scene).DEFAULTS))
                times.setdefault(("peer", tol, "", "whole"), []).append(_whole_process(code))
        log(f"  round {rep + 1}/{runs} done ({env_note})")
    med = {k: statistics.median(v) for k, v in times.items()}
    rows = []
    for tol in theirs:
        target = errors[("peer", tol, "")]
        row = {"peer_rtol": tol, "peer_error": target, "peer_in_s": med[("peer", tol, "", "in")],
               "peer_whole_s": med.get(("peer", tol, "", "whole"))}
        for kind in ("in", "whole") if whole_process else ("in",):
            ok = [(med[("ours", t, c, kind)], t, c) for t, c in variants if errors[("ours", t, c)] <= target]
            best = min(ok) if ok else None
            row[f"ours_{kind}"] = None if best is None else {"rtol": best[1], "compiled": best[2], "s": best[0],
                                                               "error": errors[("ours", best[1], best[2])]}
            row[f"ratio_{kind}"] = None if best is None else best[0] / row[f"peer_{kind}_s"]
        rows.append(row)
    return {"scene": scene, "t_final": t_final, "runs": runs, "load": env_note, "rows": rows,
            "ours": [{"rtol": t, "compiled": c, "error": errors[("ours", t, c)], "in_s": med[("ours", t, c, "in")],
                      "whole_s": med.get(("ours", t, c, "whole"))} for t, c in variants],
            "peer": [{"rtol": t, "error": errors[("peer", t, "")], "in_s": med[("peer", t, "", "in")],
                      "whole_s": med.get(("peer", t, "", "whole"))} for t in theirs]}


def duel_markdown(result: dict) -> str:
    """The table of :func:`forward_duel`."""
    head = (f"{result['scene']}, t = 0 ... {result['t_final']:g} s, medians of {result['runs']} interleaved runs "
            f"({result['load']})\n\n| peer rtol | peer error | peer s (in / whole) | our cheapest at equal or better "
            "error (in-process) | our error | our s | ratio in | ratio whole (our cheapest whole) |\n"
            "|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in result["rows"]:
        o, w = r["ours_in"], r.get("ours_whole")
        whole = "" if r.get("ratio_whole") is None else f"{r['ratio_whole']:.2f} ({w['s']:.3f} s, rtol {w['rtol']:g} {w['compiled']})"
        peer_whole = f"{r['peer_whole_s']:.3f}" if r.get("peer_whole_s") is not None else "-"
        if o is None:
            lines.append(f"| {r['peer_rtol']:g} | {r['peer_error']:.1e} | {r['peer_in_s']:.4f} / {peer_whole} | none | | | | {whole} |")
        else:
            lines.append(f"| {r['peer_rtol']:g} | {r['peer_error']:.1e} | {r['peer_in_s']:.4f} / {peer_whole} | rtol {o['rtol']:g}, "
                         f"compiled {o['compiled']} | {o['error']:.1e} | {o['s']:.4f} | {r['ratio_in']:.2f} | {whole} |")
    ours = "\n\n| our rtol | compiled | error | in-process s | whole process s |\n|---|---|---|---|---|\n" + "\n".join(
        f"| {o['rtol']:g} | {o['compiled']} | {o['error']:.1e} | {o['in_s']:.4f} | "
        f"{'' if o['whole_s'] is None else format(o['whole_s'], '.3f')} |" for o in result["ours"])
    return head + "\n".join(lines) + ours + "\n"


if __name__ == "__main__":   # python -m ocp_constraints.bench.peers [scene] [runs] [out.md]
    import sys

    res = forward_duel(sys.argv[1] if len(sys.argv) > 1 else "pendulum", runs=int(sys.argv[2]) if len(sys.argv) > 2 else 3)
    text = duel_markdown(res)
    print(text)
    if len(sys.argv) > 3:
        with open(sys.argv[3], "w") as f:
            f.write(text)
