"""Mistakes made on purpose in the newcomer problems of scripts/newcomer_problems.py (issue 13): for each,
what the user gets (the error and its message, or the solve's outcome) and how long it took (wall and
CPU seconds; the brief: named, clear, under 2 s).

    python scripts/newcomer_mistakes.py
"""
import importlib.util
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

import ocp_constraints as oc

_spec = importlib.util.spec_from_file_location("newcomer_problems", Path(__file__).parent / "newcomer_problems.py")
problems = importlib.util.module_from_spec(_spec)
sys.modules["newcomer_problems"] = problems
_spec.loader.exec_module(problems)
ns = vars(problems)
R = oc.Radau(20, degree=3)
def attempt(label, fn):
    c, w = time.process_time(), time.perf_counter()
    try:
        out = fn()
        msg = f"NO ERROR: {out}"
    except Exception as exc:
        msg = f"{type(exc).__name__}: {exc}"
    print(f"## {label} [{time.perf_counter()-w:.2f} s wall, {time.process_time()-c:.2f} s cpu]\n   {msg[:600]}\n", flush=True)

def solve(ocp, **kw):
    s = ocp.solve(R, **kw); return f"{s.status} {s.iterations} it obj {s.objective:.6g}"

def missing_final():
    o = ns["arm"](); del o.final_values["fore.psi"]; return solve(o)
attempt("arm: final fore.psi left out", missing_final)
def reversed_bound():
    o = ns["arm"](); o.bound("tau1", 10, -10)
attempt("arm: bound tau1 (10, -10)", reversed_bound)
def reversed_time():
    o = ns["arm"](); o.t_final_bounds = (3.0, 0.2); o.minimize_final_time(); return solve(o)
attempt("arm: t_final_bounds reversed", reversed_time)
def reversed_time2():
    m = ns["arm"]().model
    o = oc.OptimalControlProblem(m, t_final=1.0, t_final_bounds=(3.0, 0.2))
    o.initial({"upper.psi": 0, "fore.psi": 0, "upper.omega_z": 0, "fore.omega_z": 0}); o.minimize_effort(); return solve(o)
attempt("arm: OptimalControlProblem(t_final_bounds=(3, 0.2))", reversed_time2)
def nan_guess():
    o = ns["arm"](); o.set_guess("upper.psi", lambda t: np.nan * t); return solve(o)
attempt("arm: NaN guess", nan_guess)
def nan_initial():
    o = ns["arm"](); o.initial({"upper.psi": float("nan")}); return solve(o)
attempt("arm: NaN initial value", nan_initial)
def math_guess():
    o = ns["arm"](); o.set_guess("upper.psi", lambda t: math.sin(t)); return solve(o)
attempt("arm: guess with math.sin", math_guess)
def scalar_guess():
    o = ns["arm"](); o.set_guess("upper.psi", 0.3); return solve(o)
attempt("arm: guess given as a number", scalar_guess)
def typo_joint_force():
    o = ns["cart_pole"](bounded=False); o.joint_force("hinge@pol")
attempt("cart_pole: joint_force('hinge@pol')", typo_joint_force)
def typo_joint_force2():
    o = ns["cart_pole"](bounded=False); o.joint_force("hinge")
attempt("cart_pole: joint_force('hinge') (two-body joint)", typo_joint_force2)
def typo_mult():
    o = ns["cart_pole"](bounded=False); o.multiplier("hinge.v4")
attempt("cart_pole: multiplier('hinge.v4')", typo_mult)
def typo_cone():
    o = ns["wheel"](); o.friction_cone("contct", 0.5)
attempt("wheel: friction_cone('contct')", typo_cone)
sol = ns["cart_pole"](bounded=False).solve(R)
attempt("cart_pole: sol.loads()['hinge.F_x']", lambda: sol.loads()["hinge.F_x"])
attempt("cart_pole: sol.sample('hinge@pole.F_x')", lambda: sol.sample("hinge@pole.F_x"))
attempt("cart_pole: sol.sample('hinge.lambda')", lambda: sol.sample("hinge.lambda"))
attempt("cart_pole: sol.sample('pole.psii')", lambda: sol.sample("pole.psii"))
attempt("cart_pole: sol.interpolate('pole.psii', 0.1)", lambda: sol.interpolate("pole.psii", 0.1))
attempt("cart_pole: sol.load_about('hinge', ...)", lambda: sol.load_about("hinge", None))
attempt("spherical: no initial orientation", lambda: solve(ns["spherical"](initial_orientation=False)))
def bad_final():
    o = ns["wheel"](); o.final({"disk.z": 0.5}); return solve(o)
attempt("wheel: final disk.z = 0.5 (off the slope)", bad_final)
def rate_bound():
    o = ns["arm"](); o.bound("upper.psi_dot", -5, 5); return solve(o)
attempt("arm: bound on a rate upper.psi_dot", rate_bound)
def unknown_name():
    o = ns["arm"](); o.initial({"upper.angle": 0.0})
attempt("arm: initial of 'upper.angle'", unknown_name)
def input_initial():
    o = ns["arm"](); o.initial({"tau1": 0.0}); o.final({"tau1": 0.0}); return solve(o)
attempt("arm: initial/final input values", input_initial)
def infeasible_bound():
    o = ns["arm"](); o.bound("tau1", -0.1, 0.1); return solve(o)
attempt("arm: tau1 bounded to +-0.1 (feasible: the elbow motor's reaction turns the upper arm)", infeasible_bound)
def neg_T():
    m = ns["arm"]().model; oc.OptimalControlProblem(m, t_final=-1.0)
attempt("arm: t_final=-1", neg_T)
def weight_nan():
    o = ns["arm"](); o.minimize_effort(weight=float("nan")); return solve(o)
attempt("arm: minimize_effort(weight=nan)", weight_nan)
def cone_mu():
    o = ns["wheel"](); o.friction_cone("contact", -0.5); return solve(o)
attempt("wheel: friction_cone mu = -0.5", cone_mu)
def subj_rev():
    o = ns["cart_pole"](bounded=False); o.subject_to(ca.sumsqr(o.joint_force("hinge@pole")), 100.0, 10.0); return solve(o)
attempt("cart_pole: subject_to(lower 100 > upper 10)", subj_rev)

def quaternion_no_orientation():
    model = oc.Model("sph_q", gravity=(0.0, 0.0, -9.81))
    bob = model.add_body("bob", 1.0, np.diag([1 / 12, 1 / 12, 0.01]), rotation="quaternion")
    P = bob.point("P", (0.0, 0.0, 0.5))
    for k in range(3):
        model.add_constraint(f"ball.v{k + 1}", ca.dot(ca.DM.eye(3)[:, k], P.v), joint="ball", position=P.position[k])
    model.add_torque("motor", bob, ca.vertcat(*[model.add_input(f"t{c}") for c in "xyz"]))
    o = oc.OptimalControlProblem(model, t_final=2.0)
    o.initial({f"bob.omega_{c}": 0.0 for c in "xyz"})
    o.minimize_effort()
    return solve(o)
attempt("spherical on a quaternion: no initial orientation", quaternion_no_orientation)
def infeasible():
    o = ns["cart_pole"](); o.bound("cart.x", -0.5, 0.5); return solve(o)
attempt("cart_pole: |cart.x| <= 0.5 with the 12 N hinge-force bound (infeasible)", infeasible)
def torque_start():
    o = ns["wheel"](); o.initial({"axle": 1e3}); return solve(o)
attempt("wheel: initial axle torque 1000 N m (infeasible in the cone)", torque_start)
