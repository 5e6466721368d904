"""The suite's four-bar at a tolerance against its minimal-coordinate reference on ever finer uniform meshes.

    python scripts/four_bar_reference_convergence.py [--tolerance 1e-4] [--intervals 640 1280 2560]

``python -m ocp_constraints.bench.ocp_suite_hp --only four_bar`` judges the refined solution against one uniform
Radau 7 reference (the suite's setting, N = 640). The four-bar's pin force rides a bound on two arcs whose
junctions lie inside the reference's intervals, so that reference carries an error of its own at the tolerances
asked. Here the refined solution (``problem.solve(tolerance=...)``, the suite's problem in its default coordinates)
is compared with the reference (``ocp_suite_hp.reference``, started from it) on each ``--intervals``: a true error
that keeps falling as the reference is refined is the reference's, not ours.
"""
from __future__ import annotations

import argparse
import time

from ocp_constraints.bench import ocp_suite_hp as hp
from ocp_constraints.bench.ocp_suite_run import PROBLEMS


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--intervals", type=int, nargs="+", default=[640, 1280, 2560])
    args = ap.parse_args(argv)
    sp = next(p for p in PROBLEMS if p.name == "four_bar")
    cpu = time.process_time()
    sol = sp.ours(coordinates="auto").solve(tolerance=args.tolerance, progress=False)
    record = sol.mesh_refinement
    print(f"refined at {args.tolerance:g}: met {record['met']}, {sol.transcription.scheme.point_count} points, "
          f"estimate states {record['estimate']['states']:.2e}, {time.process_time() - cpu:.1f} s CPU", flush=True)
    for n in args.intervals:
        cpu = time.process_time()
        ref = hp.reference(sp, f"minimal-coordinate Radau7 N={n}", sol)
        print(f"reference Radau 7 x {n}: states' largest difference {hp.true_states(sp, sol, ref):.2e} "
              f"({time.process_time() - cpu:.1f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
