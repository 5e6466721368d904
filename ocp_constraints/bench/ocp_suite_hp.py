"""The suite's problems by hp mesh refinement (``problem.solve(tolerance=...)``) against the converged references.

The accuracy chain of :mod:`.ocp_suite_convergence` reaches 1e-6 of the converged minimal-coordinate
reference on uniform Radau 7 meshes (acrobot and four-bar: N = 160). Here the same problems, in the
form pinned per problem, are solved by the library's hp refinement (``ocp/mesh_refinement.py``:
short intervals at switches, high degrees where smooth) to a sequence of tolerances, and each
objective is compared with the converged reference of ``ocp_suite.csv`` (a run of
``ocp-constraints bench --ocp-suite``; the reference is the minimal-coordinate collocation, not
our code). Run::

    python -m ocp_constraints.bench.ocp_suite_hp --only acrobot four_bar --tolerances 1e-4 1e-5 1e-6

It prints one line per problem and tolerance and writes ``ocp_suite.hp.csv`` next to ``ocp_suite.csv``.
The tolerance is the refinement's (states in SI units, multipliers relative to the largest load),
not the objective's: the table shows which tolerance gives 1e-6 in the objective, and at what cost.
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

FIELDS = ["problem", "tolerance", "coordinates", "met", "refinements", "intervals", "points", "objective",
          "reference_objective", "deviation", "iterations_total", "wall_s", "cpu_s", "message"]


def run(name: str, tolerance: float, reference: float, log=print) -> dict:
    """Solve suite problem ``name`` to ``tolerance`` by hp refinement from the library's default start."""
    import ocp_constraints as oc

    from .ocp_suite_run import PROBLEMS

    sp = next(p for p in PROBLEMS if p.name == name)
    problem = sp.ours(coordinates=sp.fine_coordinates)
    started, cpu = time.perf_counter(), time.process_time()
    try:
        sol = problem.solve(tolerance=tolerance, progress=False)
    except oc.OCPSolveError as exc:
        sol = exc.solution
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu
    rec = sol.mesh_refinement or {}
    hist = rec.get("history", [])
    row = {"problem": name, "tolerance": tolerance, "coordinates": problem.nlp_coordinates, "met": rec.get("met"),
           "refinements": rec.get("refinements"), "intervals": sol.transcription.scheme.intervals,
           "points": sol.transcription.scheme.point_count, "objective": float(sol.objective),
           "reference_objective": reference, "deviation": abs(float(sol.objective) - reference) / abs(reference),
           "iterations_total": sum(h.get("iterations", 0) + h.get("companion_iterations", 0) for h in hist),
           "wall_s": wall, "cpu_s": cpu, "message": str(rec.get("message", sol.status))[:300]}
    log(f"{name} tolerance {tolerance:g}: J = {row['objective']:.12g}, deviation {row['deviation']:.1e} from "
        f"{reference:.12g}; met {row['met']}, {row['refinements']} refinements, {row['intervals']} intervals, "
        f"{row['points']} points, {row['iterations_total']} iterations, {wall:.1f} s, {cpu:.1f} s CPU")
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", default=["acrobot", "four_bar"], metavar="NAME")
    ap.add_argument("--tolerances", nargs="+", type=float, default=[1e-4, 1e-5, 1e-6])
    ap.add_argument("--suite", default="results/bench/ocp_suite.csv", help="the suite's results (converged references)")
    args = ap.parse_args(argv)
    with open(args.suite) as fh:
        refs = {r["problem"]: float(r["reference_objective"]) for r in csv.DictReader(fh)}
    rows = [run(name, tol, refs[name]) for name in args.only for tol in args.tolerances]
    out = Path(args.suite).with_name("ocp_suite.hp.csv")
    with out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, FIELDS)
        w.writeheader()
        w.writerows(rows)
    print(f"written {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
