"""The swing-up's refined solve against the cheapest fixed meshes that meet the tolerance, timed interleaved (issue 19).

    python scripts/mesh_refinement_ratio.py [--runs 11] [--tolerances 1e-4 1e-6 1e-8]

The bench (``python -m ocp_constraints.bench.mesh_refinement``) finds the cheapest fixed mesh after a
sweep and times it against the refined solve in 3 alternate runs; on a shared machine the load drifts
and 3 pairs leave the ratio noisy. Here, per tolerance, the fixed Radau meshes whose true error
(against the Pontryagin reference, as in the bench) meets it, among the few that were ever cheapest
(:data:`CANDIDATES`), and ``problem.solve(tolerance=...)`` are timed in turn, ``runs`` rounds (each round
every candidate and the refined solve once, a fresh problem each, as the bench does), after one
untimed round. Printed: median CPU (``time.process_time``) and wall of each, and the refined solve's
CPU over the cheapest candidate's (the ratio of issue 19's "no more than 2x"), also per round
(median and largest of the round-by-round ratios).
"""
from __future__ import annotations

import argparse
import statistics
import time

from ocp_constraints.bench.mesh_refinement import SwingUpTruth, _gated, _task, true_error
from ocp_constraints.ocp.schemes import Radau

# (degree, intervals) of the fixed meshes that were cheapest in bench sweeps at one tolerance or another.
CANDIDATES = [(3, 40), (4, 20), (5, 20), (6, 10), (6, 20), (7, 20), (8, 10), (9, 10), (6, 40), (8, 20), (9, 20)]


def _timed(fn):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=11)
    ap.add_argument("--tolerances", type=float, nargs="+", default=[1e-4, 1e-6, 1e-8])
    args = ap.parse_args(argv)
    truth = SwingUpTruth()
    errors = {c: _gated(true_error(_task("pendulum", "swing_up").solve(Radau(c[1], degree=c[0])), truth)) for c in CANDIDATES}
    for tol in args.tolerances:
        meeting = [c for c in CANDIDATES if errors[c] <= tol]
        runs = {"refined": [], **{c: [] for c in meeting}}
        fns = {"refined": lambda: _task("pendulum", "swing_up").solve(tolerance=tol)}
        fns.update({c: (lambda c=c: _task("pendulum", "swing_up").solve(Radau(c[1], degree=c[0]))) for c in meeting})
        for round_ in range(args.runs + 1):
            for name, fn in fns.items():
                sol, wall, cpu = _timed(fn)
                if round_:
                    runs[name].append((wall, cpu))
        refined = fns["refined"]()
        mr = refined.mesh_refinement
        med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v)) for k, v in runs.items()}
        best = min(meeting, key=lambda c: med[c][1])
        per_round = [r[1] / f[1] for r, f in zip(runs["refined"], runs[best])]
        err = _gated(true_error(refined, truth))
        print(f"tolerance {tol:g}: refined {sum(h['solves'] for h in mr['history'])} solves, final "
              f"{len(mr['degrees'])} intervals {refined.transcription.scheme.point_count} points, true error {err:.1e}, "
              f"true/estimate {err / max(mr['estimate'][q] for q in ('states', 'multipliers')):.2f}; "
              f"CPU {med['refined'][1] * 1000:.0f} ms (wall {med['refined'][0] * 1000:.0f})")
        for c in sorted(meeting, key=lambda c: med[c][1]):
            print(f"    fixed radau{c[0]} N={c[1]} (error {errors[c]:.1e}): CPU {med[c][1] * 1000:.0f} ms (wall {med[c][0] * 1000:.0f})")
        print(f"  ratio refined / cheapest (radau{best[0]} N={best[1]}): CPU {med['refined'][1] / med[best][1]:.2f}, wall "
              f"{med['refined'][0] / med[best][0]:.2f}; per round CPU median {statistics.median(per_round):.2f}, "
              f"largest {max(per_round):.2f} ({args.runs} rounds)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
