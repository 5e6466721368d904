"""``examples/bryson_denham.py``'s problem solved to each tolerance, its estimate against the closed form (issue 19).

    python scripts/bryson_denham_refinement.py [--tolerances 1e-3 1e-4 1e-5 1e-6] [--cap-s 300] [--as-path-constraint]

Per tolerance, in its own process (killed past ``--cap-s`` of wall time): met, final intervals and points, solves,
the states' estimate and true error (``max |x - x*|, |v - v*|`` over 2,001 instants against Bryson and Ho's closed
form, sec. 3.11), their ratio, the inputs' estimate and true error (the push ``u``, relative to its largest
value, reported, not gated), and CPU (``time.process_time`` of ``problem.solve``). A measurement, not a test; the
closed form is that of ``tests/test_examples.py`` (wall = 1/9 <= 1/6: junctions at t = 1/3 and 2/3).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
WALL = 1 / 9


def closed_form(t: np.ndarray, wall: float = WALL) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, v, u of Bryson and Ho's solution for ``wall <= 1/6``; ``s = min(t, 1 - t)``, off the wall for
    ``s < 3 wall``: ``x = wall (1 - (1 - s/(3 wall))^3)``, ``|v| = (1 - s/(3 wall))^2``, ``u = -2/(3 wall) (1 - s/(3 wall))``."""
    s = np.minimum(t, 1 - t)
    off = s < 3 * wall
    r = np.where(off, 1 - s / (3 * wall), 0.0)
    return (np.where(off, wall * (1 - r ** 3), wall), r ** 2 * np.where(t <= 0.5, 1.0, -1.0),
            -2 / (3 * wall) * r)


def problem(as_path: bool = False):
    """The example's problem, built by the example's own code (everything before its solve); ``as_path``: its wall
    written as a path constraint, ``subject_to(x, upper=1/9)``, instead of a bound."""
    source = (ROOT / "examples" / "bryson_denham.py").read_text().split("sol = ocp.solve")[0]
    argv, sys.argv = sys.argv, ["bryson_denham.py"]
    try:
        scope: dict = {}
        exec(compile(source, "examples/bryson_denham.py", "exec"), scope)
    finally:
        sys.argv = argv
    ocp = scope["ocp"]
    if as_path:
        del ocp.bounds["block.x"]
        ocp.subject_to(ocp.quantity("block.x"), upper=WALL, label="wall")
    return ocp


def one(tolerance: float, as_path: bool = False) -> dict:
    ocp = problem(as_path)
    cpu = time.process_time()
    sol = ocp.solve(tolerance=tolerance, progress=False)
    cpu = time.process_time() - cpu
    r = sol.mesh_refinement
    t = np.linspace(0.0, 1.0, 2001)
    x, v, u = closed_form(t)
    states = max(np.abs(sol.interpolate("block.x", t) - x).max(), np.abs(sol.interpolate("block.vbar_x", t) - v).max())
    inputs = float(np.abs(sol.interpolate("u", t) - u).max() / np.abs(u).max())
    return {"tolerance": tolerance, "met": r["met"], "intervals": r["history"][-1]["intervals"],
            "points": r["history"][-1]["points"], "solves": sum(h.get("solves", 0) for h in r["history"]),
            "states_estimate": r["estimate"]["states"], "states_true": float(states),
            "inputs_estimate": r["estimate"].get("inputs"), "inputs_true": inputs, "cpu_s": cpu,
            "objective": sol.objective, "message": r["message"][:160]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerances", nargs="*", type=float, default=[1e-3, 1e-4, 1e-5, 1e-6])
    ap.add_argument("--cap-s", type=float, default=300.0)
    ap.add_argument("--as-path-constraint", action="store_true", help="the wall as subject_to(x, upper=1/9)")
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.one is not None:
        print("ROW " + json.dumps(one(a.one, a.as_path_constraint)))
        return 0
    print("| tolerance | met | intervals / points | solves | states: true / estimate (ratio) | inputs (u, rel.): true / estimate | CPU (s) |")
    print("|---|---|---|---|---|---|---|")
    for tol in a.tolerances:
        try:
            out = subprocess.run([sys.executable, __file__, "--one", repr(tol)] + ["--as-path-constraint"] * a.as_path_constraint,
                                 capture_output=True, text=True,
                                 timeout=a.cap_s, check=True).stdout
        except subprocess.TimeoutExpired:
            print(f"| {tol:g} | cap: not done within {a.cap_s:g} s of wall time | | | | | |", flush=True)
            continue
        row = json.loads(next(line for line in out.splitlines() if line.startswith("ROW "))[4:])
        print(f"| {tol:g} | {row['met']} | {row['intervals']} / {row['points']} | {row['solves']} | "
              f"{row['states_true']:.1e} / {row['states_estimate']:.1e} ({row['states_true'] / row['states_estimate']:.2f}) | "
              f"{row['inputs_true']:.1e} / {row['inputs_estimate']:.1e} | {row['cpu_s']:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
