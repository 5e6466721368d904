"""Bang-bang inputs refined to a tolerance, against their closed forms or an independent reference (issue 19).

    python scripts/bang_bang_jumps.py [--tolerances 1e-3 1e-4 1e-5 1e-6 1e-7 1e-8] [--cases NAME ...] [--coordinates C]
        [--out results/bench/bang_bang_jumps.md]
    PYTHONPATH=<a checkout of an older commit> python scripts/bang_bang_jumps.py ...     # the same rows before a change

Three problems whose inputs no effort term holds, each from the default first mesh, ``problem.solve(tolerance=TOL)``:

- *block*: a block on a rail, force in [-1, 2] N, rest at 0 to rest at 1 m in least time; Pontryagin: 2 N up to
  1/sqrt(3) s, -1 N until sqrt(3) s (closed-form states);
- *least-fuel slider*: 1 m in 2 s, least int (up + um), each in [0, 4] N: bang-off-bang, switches at 1 -+ sqrt(3)/2 s
  (closed-form states);
- *minimum-time swing-up*: the bench's rod, |tau| <= 5 N m, one switch; reference by shooting (DOP853, rtol 1e-13:
  :class:`ocp_constraints.bench.mesh_refinement.MinimumTimeReference`);
- *least-time arm*: the seventh newcomer's URDF arm (``scripts/refinement_newcomer7/arm2.urdf``) from hanging to
  (-pi/4, pi/4) rad at rest, |shoulder| <= 6 N m, |elbow| <= 2 N m: three jumps; reference by shooting on Lagrange's
  equations from the energies (``tests/newcomer_reference.arm_least_time_shooting``; the states' error not computed).

Per row: met, points, CPU of the solve (``time.process_time``), the true states error (largest over a fine grid, SI
units) and the final-time error where free, the states' estimate, the multipliers' true error (relative to the largest
load, the instant of the jump left out: two values there) and estimate where the reference has loads (the swing-up's
hinge, by hand), and the located or imposed switch times' error.
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

import ocp_constraints as oc
from ocp_constraints.bench.mesh_refinement import MinimumTimeReference, minimum_time_swing_up, true_error

ROOT = Path(__file__).resolve().parent.parent


def block() -> oc.OptimalControlProblem:
    model = oc.Model("block", gravity=(0.0, 0.0, 0.0))
    body = model.add_body("block", 1.0, 0.1 * np.eye(3), rotation="321")
    centre = body.point("centre", (0.0, 0.0, 0.0))
    oc.joints.prismatic(model, "slider", centre, axis=(1, 0, 0), anchor=(0.0, 0.0, 0.0))
    model.add_force("push", centre, ca.vertcat(model.add_input("F"), 0, 0))
    problem = oc.OptimalControlProblem(model, t_final=2.0, t_final_bounds=(0.5, 5.0))
    problem.bound("F", -1.0, 2.0)
    problem.initial({"block.x": 0.0, "block.x_dot": 0.0})
    problem.final({"block.x": 1.0, "block.x_dot": 0.0})
    problem.minimize_final_time()
    return problem


def fuel() -> oc.OptimalControlProblem:
    model = oc.Model("fuel", gravity=(0.0, -9.81, 0.0))
    slider = model.add_body("slider", 1.0, 0.1 * np.eye(3), rotation="321")
    oc.joints.prismatic(model, "rail", slider.com, axis=(1, 0, 0))
    up, um = model.add_input("up"), model.add_input("um")
    model.add_force("thrust", slider.com, ca.vertcat(up - um, 0, 0))
    problem = oc.OptimalControlProblem(model, t_final=2.0)
    problem.initial({"slider.x": 0.0, "slider.vbar_x": 0.0})
    problem.final({"slider.x": 1.0, "slider.vbar_x": 0.0})
    problem.bound("up", 0.0, 4.0)
    problem.bound("um", 0.0, 4.0)
    problem.minimize_integral(problem.quantity("up") + problem.quantity("um"), label="fuel")
    return problem


def arm() -> oc.OptimalControlProblem:
    robot = oc.load_urdf(str(ROOT / "scripts" / "refinement_newcomer7" / "arm2.urdf"), base="ground",
                         gravity=(0.0, -9.81, 0.0))
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0, t_final_bounds=(0.1, 5.0))
    start, end = np.array([-np.pi / 2, 0.0]), np.array([-np.pi / 4, np.pi / 4])
    robot.set_boundary(problem, "initial", start)
    robot.set_boundary(problem, "final", end)
    robot.set_guess(problem, lambda s: start + (end - start) * (3 * np.clip(s, 0, 1) ** 2 - 2 * np.clip(s, 0, 1) ** 3)[:, None])
    problem.bound("shoulder.tau", -6.0, 6.0)
    problem.bound("elbow.tau", -2.0, 2.0)
    problem.minimize_final_time()
    return problem


def _arm_truth(sol):
    """The switch times and T against the shooting reference seeded from them (NaN where the structure differs)."""
    reference = sys.modules.get("newcomer_reference")
    if reference is None:       # the tests' independent references (no ocp_constraints in them)
        spec = importlib.util.spec_from_file_location("newcomer_reference", ROOT / "tests" / "newcomer_reference.py")
        reference = sys.modules["newcomer_reference"] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(reference)
    arcs = sol.mesh_refinement.get("input_arcs") or []
    ends = {q: [a["end"] for a in arcs if a["quantity"] == q][:-1] for q in ("shoulder.tau", "elbow.tau")}
    first = {q: next((a["value"] for a in arcs if a["quantity"] == q and a["start"] == 0.0), None)
             for q in ("shoulder.tau", "elbow.tau")}
    switches = sorted(s["t"] for s in sol.mesh_refinement.get("switches_located", []) if s["kind"] == "bang-bang")
    if len(ends["shoulder.tau"]) == 1 and len(ends["elbow.tau"]) == 2 and None not in first.values():
        found = [ends["elbow.tau"][0], ends["shoulder.tau"][0], ends["elbow.tau"][1]]
    elif len(switches) == 3:    # the arcs not imposed (an older library): the joint-coordinate optimum's structure
        found, first = switches, {"shoulder.tau": 6.0, "elbow.tau": -2.0}
    else:
        return float("nan"), float("nan"), [float("nan")] * 3, None
    times = reference.arm_least_time_shooting([*found, sol.t_final], first["shoulder.tau"], first["elbow.tau"])
    return float("nan"), abs(sol.t_final - times[3]), sorted(times[:3]), None


def _piecewise(t, switches, accelerations):
    """Position and speed from rest at 0 under piecewise-constant accelerations (switch times, one more acceleration)."""
    x, v, out_x, out_v = 0.0, 0.0, np.zeros_like(t), np.zeros_like(t)
    edges = [0.0, *switches, np.inf]
    for a, lo, hi in zip(accelerations, edges[:-1], edges[1:]):
        inside = (t >= lo) & (t <= hi)
        dt = t[inside] - lo
        out_x[inside], out_v[inside] = x + v * dt + a * dt**2 / 2, v + a * dt
        span = min(hi, t.max()) - lo
        x, v = x + v * span + a * span**2 / 2, v + a * span
    return out_x, out_v


def _block_truth(sol):
    t = np.linspace(0.0, sol.t_final, 4001)
    x, v = _piecewise(t, [1 / math.sqrt(3)], [2.0, -1.0])
    err = max(np.abs(sol.interpolate("block.x", t) - x).max(), np.abs(sol.interpolate("block.x_dot", t) - v).max())
    return err, abs(sol.t_final - math.sqrt(3)), [1 / math.sqrt(3)], None


def _fuel_truth(sol):
    t1 = 1 - math.sqrt(3) / 2
    t = np.linspace(0.0, 2.0, 4001)
    x, v = _piecewise(t, [t1, 2 - t1], [4.0, 0.0, -4.0])
    err = max(np.abs(sol.interpolate("slider.x", t) - x).max(), np.abs(sol.interpolate("slider.vbar_x", t) - v).max())
    return err, 0.0, [t1, 2 - t1], None


def _switch_error(sol, exact) -> float:
    """The switch times' error: the imposed arcs' junctions where the refinement imposed them, else the located ones."""
    mr = sol.mesh_refinement
    if mr.get("input_arcs"):
        found = sorted({a["end"] for a in mr["input_arcs"]} - {sol.t_final})
    else:
        found = sorted(s["t"] for s in mr.get("switches_located", []) if s["kind"] == "bang-bang")
    if len(found) != len(exact):
        return float("nan")
    return float(np.max(np.abs(np.asarray(found) - exact)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerances", type=float, nargs="+", default=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8])
    ap.add_argument("--cases", nargs="+", help="problems to run (default: all)")
    ap.add_argument("--coordinates", choices=["auto", "joint", "maximal"], help="the NLP's coordinates (default: auto)")
    ap.add_argument("--out")
    args = ap.parse_args(argv)
    reference = None

    def swing_truth(sol):
        nonlocal reference
        reference = reference or MinimumTimeReference(minimum_time_swing_up().solve(oc.Radau(160, degree=3)))
        errors = true_error(sol, reference.truth)
        return errors["states"], abs(sol.t_final - reference.t_final), [reference.t1], errors["multipliers"]

    cases = {"block": (block, _block_truth), "least-fuel slider": (fuel, _fuel_truth),
             "minimum-time swing-up": (minimum_time_swing_up, swing_truth), "least-time arm": (arm, _arm_truth)}
    lines = ["| problem | tolerance | met | points | CPU (s) | states: true / estimate | multipliers: true / estimate | "
             "final time error (s) | switch time error (s) |", "|---|---|---|---|---|---|---|---|---|"]
    for name, (build, truth) in cases.items():
        if args.cases and name not in args.cases:
            continue
        for tol in args.tolerances:
            cpu = time.process_time()
            problem = build()
            problem.coordinates = args.coordinates or problem.coordinates
            sol = problem.solve(tolerance=tol)
            cpu = time.process_time() - cpu
            mr = sol.mesh_refinement
            states, t_final, switches, loads = truth(sol)    # loads: the multipliers' true error, None where unknown
            loads = "-" if loads is None else f"{loads:.1e} / {mr['estimate']['multipliers']:.1e}"
            row = (f"| {name} | {tol:g} | {'yes' if mr['met'] else 'no'} | {sol.transcription.scheme.point_count} | "
                   f"{cpu:.2f} | {states:.1e} / {mr['estimate']['states']:.1e} | {loads} | {t_final:.1e} | "
                   f"{_switch_error(sol, switches):.1e} |")
            print(row, flush=True)
            lines.append(row)
    if args.out:
        with open(args.out, "w") as f:
            f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
