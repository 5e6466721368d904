"""Multiplier error against the integrator tolerance, every simulated scene, down to the floor (issue 14).

    python scripts/multiplier_floor.py [--out results/bench] [--scenes ...] [--no-peers]

The simulation sweep of ``ocp-constraints bench`` (:func:`ocp_constraints.bench.sweeps.sweep_sim`:
Adams and BDF at rtol = atol from 1e-4 to 1e-14, 10 s, errors against the references at DOP853's
tightest tolerance) and the simulating peers (Pinocchio, sympy), one run each (the errors do not
depend on the run; the times of ``ocp-constraints bench`` are medians of 3 and more), drawn into
``OUT/multiplier_floor.png`` with its table ``OUT/multiplier_floor.md`` (the bench writes the same
figure from its own sweeps).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ocp_constraints.bench.sweeps import SIM_SCENES, sweep_sim
from ocp_constraints.bench.work_precision import plot_multiplier_floor, run_peers


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/bench")
    ap.add_argument("--scenes", nargs="*", default=list(SIM_SCENES))
    ap.add_argument("--no-peers", action="store_true")
    args = ap.parse_args()
    rows = []
    for scene in args.scenes:
        scene_rows, meta = sweep_sim(scene, False, 1, 10.0, log=lambda m: print(m, file=sys.stderr, flush=True))
        rows += scene_rows
        print(f"{scene}: reference {meta['reference']}", file=sys.stderr)
    if not args.no_peers:
        peer_rows, notes = run_peers(args.scenes, False, 1, log=lambda m: print(m, file=sys.stderr, flush=True))
        rows += peer_rows
        for n in notes:
            print(n, file=sys.stderr)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = plot_multiplier_floor(out / "multiplier_floor.png", rows)
    (out / "multiplier_floor.md").write_text(
        "Multiplier error (max over 10 s, relative to the scene's largest reference multiplier) against the "
        "tolerance rtol = atol; `python scripts/multiplier_floor.py`.\n\n" + table)
    print(table)


if __name__ == "__main__":
    main()
