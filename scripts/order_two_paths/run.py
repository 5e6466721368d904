"""A path constraint of the coordinates alone (order two), imposed or not: the stop pendulum and Bryson-Denham.

    python run.py PROBLEM TOL [--coordinates auto|maximal]

PROBLEM: pend_sin (sin(psi) >= sin(0.5)), pend_x (the rod's centre x >= (L/2) sin 0.5), bd_wall (Bryson-Denham's x <= 1/9
as subject_to). Prints met, points, CPU, the arcs, true errors against the tests' references."""
import argparse
import json
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests"))
import ocp_constraints as oc  # noqa: E402
from test_refinement_state_arcs import LENGTH, STOP, _phase_reference, _true_errors, pendulum_on_a_stop  # noqa: E402


def pendulum(kind, coordinates):
    pr = pendulum_on_a_stop(coordinates)
    del pr.bounds["rod.psi"]
    if kind == "pend_sin":
        pr.subject_to(ca.sin(pr.quantity("rod.psi")), lower=float(np.sin(STOP)), label="stop")
    else:
        pr.subject_to(pr.quantity("rod.x"), lower=float(LENGTH / 2 * np.sin(STOP)), label="stop")
    return pr


def bd(coordinates):
    model = oc.Model("bryson_denham", gravity=(0.0, -9.81, 0.0))
    block = model.add_body("block", 1.0, np.diag([0.01, 0.01, 0.01]), rotation="321")
    oc.joints.prismatic(model, "rail", block.com, axis=(1, 0, 0))
    model.add_force("push", block.com, ca.vertcat(model.add_input("u"), 0, 0))
    pr = oc.OptimalControlProblem(model, t_final=1.0, coordinates=coordinates)
    pr.initial({"block.x": 0.0, "block.vbar_x": 1.0})
    pr.final({"block.x": 0.0, "block.vbar_x": -1.0})
    pr.subject_to(pr.quantity("block.x"), upper=1 / 9, label="wall")
    pr.minimize_effort(["u"])
    return pr


def true_pendulum(sol, record):
    t1, t2, reference = _phase_reference()
    return (*_true_errors(sol, t1, t2, reference), (t1, t2))


def true_bd(sol, record):
    t = np.linspace(0, 1, 4001)
    w = 1 / 9
    s = np.minimum(t, 1 - t)
    r = np.where(s < 3 * w, 1 - s / (3 * w), 0.0)
    x, v = np.where(s < 3 * w, w * (1 - r ** 3), w), r ** 2 * np.where(t <= 0.5, 1.0, -1.0)
    ts = max(np.abs(sol.interpolate("block.x", t) - x).max(), np.abs(sol.interpolate("block.vbar_x", t) - v).max())
    return ts, float("nan"), (1 / 3, 2 / 3)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("problem")
    ap.add_argument("tol", type=float)
    ap.add_argument("--coordinates", default="auto")
    a = ap.parse_args()
    pr = bd(a.coordinates) if a.problem == "bd_wall" else pendulum(a.problem, a.coordinates)
    c0 = time.process_time()
    sol = pr.solve(tolerance=a.tol)
    cpu = time.process_time() - c0
    rec = sol.mesh_refinement
    ts, tl, junctions = (true_bd if a.problem == "bd_wall" else true_pendulum)(sol, rec)
    est = rec["estimate"]
    row = dict(problem=a.problem, coordinates=a.coordinates, tol=a.tol, met=rec["met"], points=len(sol.t), cpu=round(cpu, 2),
               arcs=[(x["quantity"], round(x["start"], 9), round(x["end"], 9), x.get("state"), x.get("path")) for x in rec.get("input_arcs", [])],
               ref_junctions=junctions, est_states=est["states"], true_states=ts,
               ratio_states=ts / est["states"], est_loads=est["multipliers"], true_loads=tl,
               ratio_loads=tl / est["multipliers"], message=rec["message"][:300])
    print(json.dumps(row))


if __name__ == "__main__":
    main()
