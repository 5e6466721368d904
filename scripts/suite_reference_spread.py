"""How far the suite's minimal-coordinate references are from their own truth (issue 19's checks of the estimate).

    python scripts/suite_reference_spread.py [--problem walker] [--tolerance 1e-4] [--settings "minimal-coordinate Radau7 N=160" "minimal-coordinate Radau7 N=320"]

Solves the suite problem by hp refinement to ``--tolerance`` (as ``ocp_constraints.bench.ocp_suite_hp`` does),
then its minimal-coordinate reference (``ocp_suite_hp.reference``: an independent program, started from that
solution) on each setting, and prints each reference's difference from the refined solution (the "true error"
the hp bench reports) and the references' difference from each other: a check below that spread cannot tell
the solution's error from the reference's. The first setting's states are compared with the last's interpolated
linearly onto its points.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def main(argv=None) -> int:
    from ocp_constraints.bench.ocp_suite_hp import reference, true_states
    from ocp_constraints.bench.ocp_suite_run import PROBLEMS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="walker")
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--settings", nargs="+", default=["minimal-coordinate Radau7 N=160", "minimal-coordinate Radau7 N=320"])
    a = ap.parse_args(argv)
    sp = next(p for p in PROBLEMS if p.name == a.problem)
    cpu = time.process_time()
    sol = sp.ours(coordinates=sp.fine_coordinates).solve(tolerance=a.tolerance, progress=False)
    print(f"{a.problem} refined to {a.tolerance:g}: {sol.transcription.scheme.point_count} points, states estimate "
          f"{sol.mesh_refinement['estimate']['states']:.2e}, {time.process_time() - cpu:.1f} s CPU")
    refs = []
    for setting in a.settings:
        cpu = time.process_time()
        ref = reference(sp, setting, sol)
        refs.append(ref)
        print(f"{setting}: the refined solution's states differ from it by {true_states(sp, sol, ref):.2e} "
              f"({time.process_time() - cpu:.1f} s CPU)")
    first, last = refs[0], refs[-1]
    X = np.array([np.interp(first["t"], last["t"], row) for row in last["x"]])
    print(f"{a.settings[0]} against {a.settings[-1]}: states differ by {np.abs(X - first['x']).max():.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
