"""The user-problem suite's problems (bench/ocp_suite*.py) in maximal and in joint coordinates.

    python scripts/ocp_joint_coordinates_suite.py [PROBLEM ...] [--intervals 20] [--runs 1]

Per problem and coordinates: objective, IPOPT iterations, CPU and wall time from the problem's
construction to its solution (medians of --runs), largest constraint residual of the solution.
Radau 3 from each problem's own user-level guess. The problems are non-convex: where the two
forms land in different local optima the objectives say so (compare with the suite's
references, ``ocp-constraints bench --ocp-suite``).
"""
from __future__ import annotations

import argparse
import statistics
import time

import ocp_constraints as oc
from ocp_constraints.bench import ocp_suite as planar
from ocp_constraints.bench import ocp_suite_3d as spatial

PROBLEMS = ["acrobot", "cart_double_pendulum", "four_bar", "rolling_disk", "quadrotor_load", "walker"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("problems", nargs="*", default=PROBLEMS)
    ap.add_argument("--intervals", type=int, default=20)
    ap.add_argument("--runs", type=int, default=1)
    args = ap.parse_args()
    print("| problem | coordinates | objective | iterations | CPU (s) | wall (s) | max residual |")
    print("|---|---|---|---|---|---|---|")
    for name in args.problems:
        build = getattr(planar, name, None) or getattr(spatial, name)
        for coordinates in ("maximal", "joint"):
            cpu, wall = [], []
            for _ in range(args.runs):
                c, w = time.process_time(), time.perf_counter()
                try:
                    sol = build(coordinates).solve(oc.Radau(args.intervals, degree=3))
                except oc.OCPSolveError as err:
                    sol = err.solution
                cpu.append(time.process_time() - c)
                wall.append(time.perf_counter() - w)
            status = "" if sol.success else f" ({sol.status})"
            print(f"| {name} | {coordinates} | {sol.objective:.9g}{status} | {sol.iterations} | "
                  f"{statistics.median(cpu):.2f} | {statistics.median(wall):.2f} | {max(sol.residuals()):.1e} |", flush=True)


if __name__ == "__main__":
    main()
