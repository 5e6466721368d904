"""Which first mesh should ``problem.solve(tolerance=...)`` start from? Evidence across problems and tolerances (issue 19).

    python scripts/mesh_refinement_start.py [--starts 3x10 5x10 3x20 7x5] [--problems swing_up acrobot cart_double_pendulum]
                                            [--tolerances 1e-4 1e-6 1e-8] [--runs 1]

For each problem (the swing-up in the library's default coordinates; the suite's acrobot and cart
double pendulum in their pinned coordinates, :mod:`ocp_constraints.bench.ocp_suite_run`), tolerance
and first mesh (``DxN``: Radau degree D on N uniform intervals, passed as ``method``), one line: met
or not, solves, the meshes' points in order, the final points, the estimate, CPU (``time.process_time``
of the whole ``problem.solve``, median of ``runs``). Any start is the user's to choose
(``method=Radau(...)``); the library's default is the one that does best over these rows. Tolerance
1e-8 runs for the swing-up only (the suite's references are converged to ~1e-9).
"""
from __future__ import annotations

import argparse
import statistics
import time

from ocp_constraints.ocp.schemes import Radau


def _problem(name: str):
    if name == "swing_up":
        from ocp_constraints.scenes.registry import build_task

        return build_task("pendulum", "swing_up")[1]
    from ocp_constraints.bench.ocp_suite_run import PROBLEMS

    sp = next(p for p in PROBLEMS if p.name == name)
    return sp.ours(coordinates=sp.fine_coordinates)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", nargs="+", default=["3x10", "5x10", "3x20", "7x5"])
    ap.add_argument("--problems", nargs="+", default=["swing_up", "acrobot", "cart_double_pendulum"])
    ap.add_argument("--tolerances", nargs="+", type=float, default=[1e-4, 1e-6, 1e-8])
    ap.add_argument("--runs", type=int, default=1)
    args = ap.parse_args(argv)
    _problem("swing_up").solve(tolerance=1e-4)         # imports and first calls
    for name in args.problems:
        for tol in args.tolerances:
            if tol < 1e-7 and name != "swing_up":
                continue
            for start in args.starts:
                d, N = (int(v) for v in start.split("x"))
                cpus = []
                for _ in range(args.runs):
                    problem = _problem(name)
                    cpu = time.process_time()
                    sol = problem.solve(Radau(N, degree=d), tolerance=tol, progress=False)
                    cpus.append(time.process_time() - cpu)
                mr = sol.mesh_refinement
                points = " -> ".join(str(h["points"]) + ("j" if "judged_against" in h else "") for h in mr["history"])
                est = max(mr["estimate"][q] for q in ("states", "multipliers"))
                print(f"{name:22s} tol {tol:g} start radau{d} N={N}: met {mr['met']}, "
                      f"{sum(h['solves'] for h in mr['history'])} solves, meshes {points} points (j: judged against a "
                      f"finer one), estimate {est:.1e}, CPU {statistics.median(cpus):.2f} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
