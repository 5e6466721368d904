"""IPOPT's first barrier parameter for a refinement's warm solves (``mesh_refinement.WARM_IPOPT``), compared (issue 19).

    python scripts/mesh_refinement_warm_mu.py [--mu 1e-6 1e-8] [--runs 5] [--suite]

For each value, ``problem.solve(tolerance=...)`` of the swing-up at 1e-4, 1e-6, 1e-8 with
``WARM_IPOPT = {"ipopt.mu_init": value}`` (the first mesh's cold solve is not affected): IPOPT
iterations of every solve, the largest estimate (it must not move: the same optimum), median CPU
(``time.process_time``) of ``runs``, the values interleaved run by run. ``--suite``: also the acrobot
and the cart double pendulum (the suite's problems, ``bench.ocp_suite_run.PROBLEMS``, in their
pinned coordinates) at 1e-4 and 1e-6, once each: solves, points, total IPOPT iterations, estimate, CPU.
The switching cases: ``python -m ocp_constraints.bench.mesh_refinement --switching-only ...`` (the bench).
"""
from __future__ import annotations

import argparse
import statistics
import time

from ocp_constraints.ocp import mesh_refinement
from ocp_constraints.scenes.registry import build_task


def _solve(problem, tol: float):
    cpu = time.process_time()
    sol = problem.solve(tolerance=tol)
    return sol, time.process_time() - cpu


def _summary(sol) -> str:
    mr = sol.mesh_refinement
    its = [(h.get("iterations"), h.get("companion_iterations")) for h in mr["history"]]
    est = max(mr["estimate"][q] for q in ("states", "multipliers"))
    return (f"{sum(h['solves'] for h in mr['history'])} solves, {sol.transcription.scheme.point_count} points, "
            f"iterations {its}, estimate {est:.3e}, met {mr['met']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", type=float, nargs="+", default=[1e-6, 1e-8])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--suite", action="store_true")
    args = ap.parse_args(argv)
    original = dict(mesh_refinement.WARM_IPOPT)
    try:
        cpu = {(mu, tol): [] for mu in args.mu for tol in (1e-4, 1e-6, 1e-8)}
        last = {}
        for _ in range(args.runs):
            for mu in args.mu:
                mesh_refinement.WARM_IPOPT = {"ipopt.mu_init": mu}
                for tol in (1e-4, 1e-6, 1e-8):
                    sol, c = _solve(build_task("pendulum", "swing_up")[1], tol)
                    cpu[(mu, tol)].append(c)
                    last[(mu, tol)] = _summary(sol)
        for mu in args.mu:
            for tol in (1e-4, 1e-6, 1e-8):
                print(f"mu_init {mu:g}, swing-up {tol:g}: {last[(mu, tol)]}, CPU {1000 * statistics.median(cpu[(mu, tol)]):.0f} ms")
        if args.suite:
            from ocp_constraints.bench.ocp_suite_run import PROBLEMS

            for sp in (p for p in PROBLEMS if p.name in ("acrobot", "cart_double_pendulum")):
                for tol in (1e-4, 1e-6):
                    for mu in args.mu:
                        mesh_refinement.WARM_IPOPT = {"ipopt.mu_init": mu}
                        sol, c = _solve(sp.ours(coordinates=sp.fine_coordinates), tol)
                        total = sum((h.get("iterations") or 0) + (h.get("companion_iterations") or 0)
                                    for h in sol.mesh_refinement["history"])
                        print(f"mu_init {mu:g}, {sp.name} {tol:g}: {_summary(sol)}, {total} iterations in all, CPU {c:.2f} s")
    finally:
        mesh_refinement.WARM_IPOPT = original
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
