"""The suite's problems by hp mesh refinement (``problem.solve(tolerance=...)``) against the converged references.

The accuracy chain of :mod:`.ocp_suite_convergence` reaches 1e-6 of the converged minimal-coordinate
reference on uniform Radau 7 meshes (acrobot and four-bar: N = 160). Here the same problems, in the
form pinned per problem, are solved by the library's hp refinement (``ocp/mesh_refinement.py``:
short intervals at switches, high degrees where smooth) to a sequence of tolerances, and each is
checked against the minimal-coordinate reference, an independent program (:mod:`.ocp_suite_peers`,
``collocate`` on :mod:`.ocp_suite_minimal`) on the mesh where the suite's chain found it converged
(``reference_setting`` of ``ocp_suite.csv``), started from our refined solution mapped into its
coordinates (:mod:`.ocp_suite_maps`: the same local optimum) and solved to IPOPT's tolerance:

- the objective's relative deviation from the suite's converged reference objective;
- the *true error* of the states the reference has (the minimal coordinates and their rates: angles
  in rad, rad/s; the cart's position in m, m/s), the largest over the reference's collocation points;
- the *estimate* of the same states (:data:`~ocp_constraints.ocp.error_estimate.SAFETY` times their
  largest difference from the companion on the final mesh, solved again here, untimed, as the
  refinement solves it), and the library's own estimate of all states (``mesh_refinement["estimate"]``);
- ``--uniform``: uniform Radau 7 meshes of the chain, each solved cold from the default guess (what a
  user does), their true error against the same reference, and the cheapest that meets the tolerance.

Run::

    python -m ocp_constraints.bench.ocp_suite_hp --only acrobot four_bar cart_double_pendulum walker --tolerances 1e-4 1e-6 --uniform

It prints one line per problem and tolerance and writes ``ocp_suite_hp.csv`` next to ``ocp_suite.csv``.
The tolerance is the refinement's (states in SI units, multipliers relative to the largest load).
Times: wall and CPU (``time.process_time``) of the whole ``problem.solve`` call.
"""
from __future__ import annotations

import argparse
import csv
import re
import time
from pathlib import Path

import numpy as np

FIELDS = ["problem", "tolerance", "coordinates", "met", "refinements", "solves", "intervals", "points", "objective",
          "reference_objective", "deviation", "true_states", "estimate_states", "true_over_estimate",
          "library_estimate_states", "library_estimate_multipliers", "iterations_total", "wall_s", "cpu_s",
          "uniform_meeting", "uniform_true_states", "uniform_wall_s", "uniform_cpu_s", "uniform_sweep", "switches",
          "history", "message"]
WARM = {"ipopt.mu_init": 1e-6}


def _setting(text: str) -> tuple[int, int]:
    """``(N, degree)`` of a reference setting such as ``minimal-coordinate Radau7 N=320``."""
    m = re.search(r"Radau(\d+) N=(\d+)", text)
    if not m:
        raise ValueError(f"reference setting {text!r} is not 'Radau<d> N=<N>'")
    return int(m.group(2)), int(m.group(1))


def reference(sp, setting: str, sol) -> dict:
    """The minimal-coordinate reference on ``setting``'s mesh, started from ``sol`` mapped into its coordinates."""
    from .ocp_suite_peers import collocate

    N, d = _setting(setting)
    return collocate(sp.minimal(), N, d, WARM, start=lambda s: sp.states(sol, sp.inputs, s))


def true_states(sp, sol, ref: dict) -> float:
    """Largest difference of ``sol``'s minimal states from the reference's, at the reference's points."""
    X, _ = sp.states(sol, sp.inputs, ref["t"])
    return float(np.abs(X - ref["x"]).max())


def estimate_states(sp, sol, companion) -> float:
    """The estimate (SAFETY times the difference from the companion, on the estimate's own grid) of
    the same minimal states as :func:`true_states`."""
    from ..ocp.error_estimate import SAFETY, sample_grid

    fractions, _ = sample_grid(sol.transcription)
    a, _ = sp.states(sol, sp.inputs, fractions * sol.t_final)
    b, _ = sp.states(companion, sp.inputs, fractions * companion.t_final)
    return SAFETY * float(np.abs(a - b).max())


def _timed_solve(problem, *args, **kwargs):
    import ocp_constraints as oc

    started, cpu = time.perf_counter(), time.process_time()
    try:
        sol = problem.solve(*args, progress=False, **kwargs)
    except oc.OCPSolveError as exc:
        if str(getattr(exc.solution, "status", "")).startswith("interrupted by"):
            raise       # a signal (Ctrl-C, a time limit) ends the bench, not only this solve
        sol = exc.solution
    return sol, time.perf_counter() - started, time.process_time() - cpu


def uniform_sweep(sp, ref_setting: str, tolerances, log=print) -> list[dict]:
    """Uniform Radau 7 meshes of the suite's chain (``sp.fine`` doubling, below the reference's), cold."""
    import ocp_constraints as oc

    rows, (N, d) = [], sp.fine
    last, _ = _setting(ref_setting)
    while N < last:
        problem = sp.ours(coordinates=sp.fine_coordinates)
        sol, wall, cpu = _timed_solve(problem, oc.Radau(N, degree=d))
        ref = reference(sp, ref_setting, sol)
        row = {"N": N, "degree": d, "true_states": true_states(sp, sol, ref), "wall_s": wall, "cpu_s": cpu,
               "success": bool(sol.success)}
        log(f"  {sp.name} uniform Radau{d} N={N}: true state error {row['true_states']:.1e}, {wall:.1f} s, {cpu:.1f} s CPU")
        rows.append(row)
        if row["true_states"] <= min(tolerances):
            break
        N *= 2
    return rows


def _step(h: dict) -> str:
    """One refinement in a few words: mesh, estimate of the states, resolved or not, CPU of both solves."""
    e = h.get("estimate", {})
    split = f" split@{len(h['switches'])} switches" if h.get("switches") else ""
    return (f"{h['intervals']}x{h['points']}pts est {e.get('states', float('nan')):.1e}/{e.get('multipliers', float('nan')):.1e}"
            f"{'' if h.get('resolved', True) else ' unresolved'}{split} {h.get('cpu_s', 0) + h.get('companion_cpu_s', 0):.1f}s"
            f" it {h.get('iterations', 0)}+{h.get('companion_iterations', 0)}")


def _switches(sol) -> str:
    """The switches of the final solution's bounds and path constraints (:mod:`~ocp_constraints.ocp.switch_detection`)."""
    from ..ocp.switch_detection import detect_switches

    found = detect_switches(sol)
    return "; ".join(f"{w.kind} of '{w.quantity}' at {w.fraction:.4f}{' inside' if w.inside else ''}" for w in found[:8]) + (
        f"; ... {len(found)} in all" if len(found) > 8 else "")


def run(sp, tolerance: float, suite_row: dict, sweep: list[dict] | None = None, log=print,
        max_refinements: int | None = None) -> dict:
    """Solve suite problem ``sp`` to ``tolerance`` by hp refinement from the library's default start and check it."""
    from ..errors import OCPSolveError
    from ..ocp.mesh_refinement import WARM_IPOPT, companion_of, solve_to_tolerance

    problem = sp.ours(coordinates=sp.fine_coordinates)
    if max_refinements is None:
        sol, wall, cpu = _timed_solve(problem, tolerance=tolerance)
    else:       # problem.solve takes no max_refinements: the refinement itself, as problem.solve calls it
        started, c0 = time.perf_counter(), time.process_time()
        try:
            sol = solve_to_tolerance(problem, tolerance, progress=False, max_refinements=max_refinements)
        except OCPSolveError as exc:       # keeps its solution (the last iterate)
            sol = exc.solution
        wall, cpu = time.perf_counter() - started, time.process_time() - c0
    rec = sol.mesh_refinement or {}
    hist = rec.get("history", [])
    reference_objective = float(suite_row["reference_objective"])
    # Untimed: the final mesh's companion again (as the refinement solved it) and the reference.
    companion = problem.solve(companion_of(sol.transcription.scheme), WARM_IPOPT, warm_start=sol, progress=False)
    ref = reference(sp, suite_row["reference_setting"], sol)
    true, est = true_states(sp, sol, ref), estimate_states(sp, sol, companion)
    row = {"problem": sp.name, "tolerance": tolerance, "coordinates": problem.nlp_coordinates, "met": rec.get("met"),
           "refinements": rec.get("refinements"),
           "solves": sum((0 if h.get("solved_as_companion") else 1) + ("companion_iterations" in h) for h in hist),
           "intervals": sol.transcription.scheme.intervals, "points": sol.transcription.scheme.point_count,
           "objective": float(sol.objective), "reference_objective": reference_objective,
           "deviation": abs(float(sol.objective) - reference_objective) / abs(reference_objective),
           "true_states": true, "estimate_states": est, "true_over_estimate": true / est if est > 0 else float("nan"),
           "library_estimate_states": rec.get("estimate", {}).get("states"),
           "library_estimate_multipliers": rec.get("estimate", {}).get("multipliers"),
           "iterations_total": sum(h.get("iterations", 0) + h.get("companion_iterations", 0) for h in hist),
           "wall_s": wall, "cpu_s": cpu, "message": str(rec.get("message", sol.status))[:300],
           "history": " -> ".join(_step(h) for h in hist), "switches": _switches(sol)}
    if sweep:
        meeting = next((u for u in sweep if u["true_states"] <= max(tolerance, true)), None)
        row["uniform_sweep"] = "; ".join(f"N={u['N']}: {u['true_states']:.1e} {u['cpu_s']:.2f} s CPU" for u in sweep)
        row["uniform_meeting"] = "none coarser than the reference's mesh"
        if meeting:
            row.update(uniform_meeting=f"Radau{meeting['degree']} N={meeting['N']}", uniform_true_states=meeting["true_states"],
                       uniform_wall_s=meeting["wall_s"], uniform_cpu_s=meeting["cpu_s"])
    log(f"  {sp.name} tolerance {tolerance:g} history: {row['history']}")
    log(f"{sp.name} tolerance {tolerance:g}: met {row['met']}, {row['refinements']} refinements, {row['solves']} solves, "
        f"{row['intervals']} intervals, {row['points']} points; true state error {true:.1e}, estimate {est:.1e} "
        f"(true/estimate {row['true_over_estimate']:.2f}; library's all-state estimate {row['library_estimate_states']:.1e}); "
        f"J deviation {row['deviation']:.1e}; {wall:.1f} s, {cpu:.1f} s CPU"
        + (f"; cheapest uniform meeting max(tolerance, true error): {row['uniform_meeting']}"
           + (f" {row['uniform_cpu_s']:.2f} s CPU" if "uniform_cpu_s" in row else "") if sweep else ""))
    return row


def main(argv=None) -> int:
    from .ocp_suite_run import PROBLEMS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", default=["acrobot", "four_bar", "cart_double_pendulum", "walker"], metavar="NAME")
    ap.add_argument("--tolerances", nargs="+", type=float, default=[1e-4, 1e-6])
    ap.add_argument("--uniform", action="store_true", help="also the uniform Radau 7 meshes of the chain, cold")
    ap.add_argument("--suite", default="results/bench/ocp_suite.csv", help="the suite's results (converged references)")
    ap.add_argument("--out", default=None, help="default: ocp_suite_hp.csv next to --suite")
    ap.add_argument("--max-refinements", type=int, default=None, help="cap the refinements (default the library's, 10)")
    args = ap.parse_args(argv)
    with open(args.suite) as fh:
        suite = {r["problem"]: r for r in csv.DictReader(fh)}
    rows = []
    for name in args.only:
        sp = next(p for p in PROBLEMS if p.name == name)
        sweep = uniform_sweep(sp, suite[name]["reference_setting"], args.tolerances) if args.uniform else None
        rows += [run(sp, tol, suite[name], sweep, max_refinements=args.max_refinements) for tol in args.tolerances]
    out = Path(args.out) if args.out else Path(args.suite).with_name("ocp_suite_hp.csv")
    with out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, FIELDS)
        w.writeheader()
        w.writerows(rows)
    print(f"written {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
