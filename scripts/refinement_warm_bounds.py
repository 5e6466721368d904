"""Warm solves of mesh refinement with IPOPT's default bound push (1e-2) and with the library's (1e-9).

    python scripts/refinement_warm_bounds.py [--tolerances 1e-4 1e-5] [--problem bryson_denham|SCENE.TASK]

Solves ``problem.solve(tolerance=TOL)`` twice per tolerance, once with ``mesh_refinement.WARM_IPOPT`` as the
library sets it and once with ``bound_push`` / ``bound_frac`` back at IPOPT's 1e-2 (``mu_init`` 1e-8 in both),
and prints per run: CPU seconds (``time.process_time``), met, final points, the estimate per quantity and the
IPOPT iterations of every solve (points, iterations). ``bryson_denham``: ``examples/bryson_denham.py``'s problem
(an arc on the wall x <= 1/9); ``SCENE.TASK``: a built-in task (e.g. ``pendulum.swing_up``). A measurement, not a test.
"""
from __future__ import annotations

import argparse
import sys
import time

import ocp_constraints.ocp.mesh_refinement as mr

LIBRARY = dict(mr.WARM_IPOPT)
IPOPT_PUSH = {**LIBRARY, "ipopt.bound_push": 1e-2, "ipopt.bound_frac": 1e-2}


def problem(name: str):
    if name == "bryson_denham":
        from bryson_denham_refinement import problem as bryson_denham     # this folder's: the example's own code

        return bryson_denham()
    from ocp_constraints.scenes.registry import build_task

    scene, task = name.split(".")
    return build_task(scene, task)[1]


def run(name: str, tolerance: float, warm: dict) -> str:
    mr.WARM_IPOPT = warm
    solves, timed = [], mr._timed_solve

    def counted(problem_, scheme, options, start, progress, first=None, fallback=None):
        out = timed(problem_, scheme, options, start, progress, first, fallback)
        solves.append((scheme.point_count, out[0].iterations))
        return out

    mr._timed_solve = counted
    try:
        cpu = time.process_time()
        sol = problem(name).solve(tolerance=tolerance, progress=False)
        cpu = time.process_time() - cpu
    finally:
        mr._timed_solve, mr.WARM_IPOPT = timed, LIBRARY
    r = sol.mesh_refinement
    estimate = ", ".join(f"{q} {v:.2e}" for q, v in r["estimate"].items())
    return (f"cpu {cpu:.1f} s, met {r['met']}, {r['history'][-1]['points']} points, estimate {estimate}; "
            f"solves (points, IPOPT iterations): {solves}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerances", nargs="*", type=float, default=[1e-4, 1e-5])
    ap.add_argument("--problem", default="bryson_denham")
    args = ap.parse_args()
    for tol in args.tolerances:
        for label, warm in (("library (bound push 1e-9)", LIBRARY), ("IPOPT's bound push 1e-2", IPOPT_PUSH)):
            print(f"{args.problem} at {tol:g}, {label}: {run(args.problem, tol, warm)}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
