"""Where the swing-up's refined solve spends its time, mesh by mesh, beside the cheapest fixed mesh (issue 19).

    python scripts/swing_up_solve_timings.py [--runs 10] [--tolerance 1e-6] [--fixed 6 20]

Each NLP's own timings (``OCPSolution.wall_time``: its build, IPOPT's set-up and the solve), medians over ``runs``
fresh problems after two untimed ones, for every NLP of ``problem.solve(tolerance=...)`` in order (the first mesh, the
pilot, the companions) and for the fixed Radau mesh; then each whole ``solve`` (CPU), whose remainder is the problem's
set-up, the warm starts, the error estimates and the switch checks.
"""
from __future__ import annotations

import argparse
import statistics
import time

import ocp_constraints.ocp.transcription as transcription
from ocp_constraints.bench.mesh_refinement import _task
from ocp_constraints.ocp.schemes import Radau


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--tolerance", type=float, default=1e-6)
    ap.add_argument("--fixed", type=int, nargs=2, default=[6, 20], metavar=("DEGREE", "INTERVALS"))
    args = ap.parse_args(argv)
    seen: list = []
    solve = transcription.Transcription.solve

    def recorded(self, *a, **k):
        sol = solve(self, *a, **k)
        seen.append((self.scheme.point_count, sol.iterations, dict(sol.wall_time)))
        return sol

    transcription.Transcription.solve = recorded
    runs = {"refined": lambda: _task("pendulum", "swing_up").solve(tolerance=args.tolerance),
            "fixed": lambda: _task("pendulum", "swing_up").solve(Radau(args.fixed[1], degree=args.fixed[0]))}
    for name, run in runs.items():
        per_nlp, whole = {}, []
        for r in range(args.runs + 2):
            seen.clear()
            cpu = time.process_time()
            sol = run()
            if r >= 2:
                whole.append(time.process_time() - cpu)
                for i, entry in enumerate(seen):
                    per_nlp.setdefault(i, []).append(entry)
            del sol     # freed outside the timed part (CasADi's and IPOPT's objects take ~30 ms), as the ratio script does
        label = f"tolerance {args.tolerance:g}" if name == "refined" else f"Radau {args.fixed[0]} x {args.fixed[1]}"
        nlps = sum(statistics.median(e[2][k] for e in entries) for entries in per_nlp.values() for k in entries[0][2])
        print(f"{name} ({label}): whole solve {statistics.median(whole) * 1e3:.1f} ms CPU (median of {args.runs}), "
              f"of which outside the NLPs' builds and solves {(statistics.median(whole) - nlps) * 1e3:.1f} ms")
        for i, entries in per_nlp.items():
            med = {k: statistics.median(e[2][k] for e in entries) * 1e3 for k in entries[0][2]}
            print(f"  NLP {i + 1}: {entries[0][0]} points, {entries[0][1]} iterations; build {med['transcription']:.1f} ms, "
                  f"IPOPT set-up {med['solver_setup']:.1f} ms, solve {med['solve']:.1f} ms (wall)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
