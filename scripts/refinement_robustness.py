"""``problem.solve(tolerance=...)`` on every optimal-control problem we have (issue 19): does the mesh
refinement meet the tolerance, stop honestly with a message, run past a time cap, or raise?

    python scripts/refinement_robustness.py [--tolerances 1e-3 1e-5] [--only NAME ...] [--cap-s 120]
        [--json results/bench/refinement_robustness.json] [--markdown results/bench/refinement_robustness.md]
        [--notes NOTES.md] [--table-only]
    python scripts/refinement_robustness.py --one NAME TOL        # one run, its row as JSON on stdout

The problems are the set of ``scripts/ocp_default_robustness.py`` (scene tasks, suite problems, newcomer
problems, the examples' OCPs, the satellite), built by its own builders (imported, not copied), each in its
default coordinates and from its default guess; none was written or tuned for the refinement. Each run is
``problem.solve(tolerance=TOL, progress=False)`` in its own ``python`` subprocess (``--one``) under a
wall-clock cap: a run over the cap is killed and reported as such. Per run: met, the message's first 150
characters, refinements, solves, the returned solution's intervals and points, the estimate of each gated quantity (states,
multipliers; inputs and final time shown too), an IPOPT failure (``OCPSolveError``'s text), any other
exception (a library error with its message, or a bug: a raw exception's type, text and the frame it
came from), CPU (``time.process_time`` of build + solve inside the child; and the child's whole CPU from
``getrusage``, import included) and wall. Rows are kept in ``--json`` (a re-run replaces its own rows),
and the table is written after every row.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
import traceback
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
ROOT = Path(__file__).resolve().parent.parent
MARK = "ROW-JSON "
SOLVE = "SOLVE "


def _problems() -> dict:
    """The builders of ``scripts/ocp_default_robustness.py`` (name -> builder), imported from it."""
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import ocp_default_robustness
    finally:
        sys.path.pop(0)
    return ocp_default_robustness.PROBLEMS


def _names() -> list[str]:
    return list(_problems())


def _where(exc: BaseException) -> str:
    """The innermost frame of the library (or else the last one) that raised ``exc``: file:line function."""
    frames = traceback.extract_tb(exc.__traceback__)
    ours = [f for f in frames if "ocp_constraints" in f.filename] or frames
    f = ours[-1] if ours else None
    return f"{Path(f.filename).name}:{f.lineno} {f.name}" if f else "?"


def _log_solves() -> None:
    """Print every solve of the refinement as it ends (mesh, IPOPT iterations, CPU and wall s), flushed:
    of a run killed at the cap, :func:`run` keeps these lines, which say where its time went. A wrapper
    of the refinement's own ``_timed_solve`` in this child process only; the library is unchanged."""
    from ocp_constraints.ocp import mesh_refinement

    solve = mesh_refinement._timed_solve

    def logged(problem, scheme, *args, **kwargs):
        started = time.process_time()
        try:
            sol, elapsed, cpu = solve(problem, scheme, *args, **kwargs)
        except Exception:
            print(f"{SOLVE}{scheme.intervals}x{scheme.point_count} failed after "
                  f"{time.process_time() - started:.1f} s CPU", flush=True)
            raise
        print(f"{SOLVE}{scheme.intervals}x{scheme.point_count} {sol.iterations} it {cpu:.1f} s CPU "
              f"{elapsed:.1f} s wall", flush=True)
        return sol, elapsed, cpu

    mesh_refinement._timed_solve = logged


def one(name: str, tol: float) -> dict:
    """Build ``name`` and solve it to ``tol``; the row (see the module's notes)."""
    import numpy as np

    import ocp_constraints as oc
    from ocp_constraints.errors import OcpConstraintsError

    row = {"problem": name, "tolerance": tol, "outcome": "?", "met": False}
    _log_solves()
    cpu, wall = time.process_time(), time.perf_counter()
    record = None
    try:
        problem = _problems()[name]()
        row["coordinates"] = problem.nlp_coordinates
        sol = problem.solve(tolerance=tol, progress=False)
        record = sol.mesh_refinement
        row["outcome"] = "met" if record.get("met") else "not met"
    except oc.OCPSolveError as exc:
        row.update(outcome="IPOPT failed", error=f"{exc}"[:300])
        record = getattr(getattr(exc, "solution", None), "mesh_refinement", None)
    except OcpConstraintsError as exc:        # a library error: it names what is wrong (or should)
        row.update(outcome="library error", error=f"{type(exc).__name__}: {exc}"[:300], where=_where(exc))
    except Exception as exc:                    # anything else is a bug: a raw exception reaches the user
        row.update(outcome="raised", error=f"{type(exc).__name__}: {exc}"[:300], where=_where(exc),
                   traceback=traceback.format_exc()[-3000:])
    row.update(cpu_s=time.process_time() - cpu, wall_s=time.perf_counter() - wall)
    if record:
        history = record.get("history", [])
        # The mesh of the solution returned: the last estimated (a mesh IPOPT then failed on comes after it in the
        # history), or an earlier one with a lower estimate (returned_refinement).
        returned = record.get("returned_refinement", record.get("refinements"))
        last = history[returned] if returned is not None and returned < len(history) else (history[-1] if history else {})
        est = record.get("estimate") or last.get("estimate") or {}
        row.update(met=bool(record.get("met")), message=str(record.get("message", ""))[:150],
                   refinements=record.get("refinements", len(history) - 1),
                   solves=int(sum(e.get("solves", 0) for e in history)),
                   iterations=int(sum(e.get("iterations", 0) + e.get("companion_iterations", 0) for e in history)),
                   intervals=last.get("intervals"), points=last.get("points"),
                   estimate={k: (float(v) if v is not None else None) for k, v in est.items()},
                   meshes=[(e.get("intervals"), e.get("points"), (e.get("estimate") or {}).get("states"),
                            (e.get("estimate") or {}).get("multipliers"), e.get("resolved", True)) for e in history],
                   nonsmooth=len(record.get("nonsmooth_intervals", [])), jump_windows=len(record.get("jump_windows", [])))
        bad = [k for k, v in row["estimate"].items() if v is None or not np.isfinite(v)]
        if row["met"] and (bad or any(row["estimate"].get(q, 1.0) == 0.0 for q in ("states", "multipliers"))):
            row["implausible"] = f"met with estimate {row['estimate']}"
    return row


def run(name: str, tol: float, cap_s: float) -> dict:
    """``one(name, tol)`` in a subprocess killed after ``cap_s`` s of wall; its row, CPU from getrusage."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--one", name, repr(tol)],
                              capture_output=True, text=True, timeout=cap_s, cwd=ROOT)
    except subprocess.TimeoutExpired as exc:
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        solves = [x[len(SOLVE):] for x in out.splitlines() if x.startswith(SOLVE)]
        return {"problem": name, "tolerance": tol, "outcome": "cap", "met": False,
                "message": f"killed at the {cap_s:g} s wall cap after {len(solves)} solves: " + "; ".join(solves),
                "solve_log": solves, "wall_s": time.perf_counter() - wall,
                "process_cpu_s": (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)}
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    lines = [x for x in done.stdout.splitlines() if x.startswith(MARK)]
    if lines:
        row = json.loads(lines[-1][len(MARK):])
    else:       # the child died without a row (a crash in C, out of memory): its stderr's tail
        row = {"problem": name, "tolerance": tol, "outcome": "crashed", "met": False,
               "error": f"exit {done.returncode}: " + done.stderr[-300:]}
    row["process_cpu_s"] = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    row["process_wall_s"] = time.perf_counter() - wall
    return row


def _g(x, fmt=".1e") -> str:
    return "" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)


def table(rows: list[dict], order: list[str]) -> str:
    out = ["| problem | tol | outcome | refinements (solves) | final intervals / points | estimate: states / multipliers "
           "(inputs / T) | meshes: intervals x points, states / multipliers estimate | CPU s (child total) | wall s | "
           "message or error (first 150 characters) |", "|---" * 10 + "|"]
    rows = sorted(rows, key=lambda r: (r["tolerance"] < 1e-4, order.index(r["problem"]) if r["problem"] in order else 99))
    for r in rows:
        e = r.get("estimate") or {}
        meshes = " -> ".join(f"{n}x{p} {_g(s)}/{_g(m)}" + ("" if ok else " (unresolved)")
                             for n, p, s, m, ok in r.get("meshes", []))
        text = r.get("message", "") if r["outcome"] in ("met", "not met", "cap") else r.get("error", "")
        if r.get("where"):
            text += f" [at {r['where']}]"
        if r.get("implausible"):
            text += f" **implausible: {r['implausible']}**"
        outcome = r["outcome"] if r["outcome"] in ("met", "not met") else f"**{r['outcome']}**"
        cells = [r["problem"], f"{r['tolerance']:g}", outcome,
                 f"{r.get('refinements', '')} ({r.get('solves', '')})" if "refinements" in r else "",
                 f"{r.get('intervals', '')} / {r.get('points', '')}" if "points" in r else "",
                 f"{_g(e.get('states'))} / {_g(e.get('multipliers'))} ({_g(e.get('inputs'))} / {_g(e.get('final_time'))})"
                 if e else "", meshes, f"{_g(r.get('cpu_s'), '.1f')} ({_g(r.get('process_cpu_s'), '.1f')})",
                 _g(r.get("wall_s", r.get("process_wall_s")), ".1f"), text.replace("|", "/").replace("\n", " ")[:400 if r["outcome"] != "cap" else 1200]]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def summary(rows: list[dict]) -> str:
    out = []
    for tol in sorted({r["tolerance"] for r in rows}, reverse=True):
        mine = [r for r in rows if r["tolerance"] == tol]
        count = {k: sum(r["outcome"] == k for r in mine) for k in
                 ("met", "not met", "cap", "IPOPT failed", "library error", "raised", "crashed")}
        implausible = sum(bool(r.get("implausible")) for r in mine)
        out.append(f"- tolerance {tol:g}, {len(mine)} problems: {count['met']} met, {count['not met']} stopped with a "
                   f"message ('met' false), {count['cap']} hit the cap, {count['IPOPT failed']} IPOPT failures "
                   f"(OCPSolveError), {count['library error']} other library errors, {count['raised']} raw exceptions, "
                   f"{count['crashed']} crashed; {implausible} 'met' with an implausible estimate.")
    return "\n".join(out)


def write(rows: list[dict], path: Path, argv: list[str], order: list[str], notes: str = "") -> None:
    import platform

    head = (f"# `problem.solve(tolerance=...)` on every optimal-control problem we have\n\n"
            f"Written by `python scripts/refinement_robustness.py {' '.join(argv)}` "
            f"({time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, Python {platform.python_version()}, "
            f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores, shared). Each run in its own "
            f"subprocess; CPU: time.process_time of build + solve in the child (the child's whole CPU, imports "
            f"included, in brackets); wall: build + solve. Estimates: states absolute (SI), multipliers relative "
            f"to the largest load; inputs and final time are not gated.\n\n")
    tmp = path.with_suffix(".tmp")
    tmp.write_text(head + "## Summary\n\n" + summary(rows) + "\n\n" + (notes.strip() + "\n\n" if notes else "")
                   + "## Runs\n\n" + table(rows, order) + "\n")
    tmp.replace(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--one", nargs=2, metavar=("NAME", "TOL"), help="one run in this process; its row as JSON")
    ap.add_argument("--tolerances", nargs="*", type=float, default=[1e-3, 1e-5])
    ap.add_argument("--only", nargs="*", default=None, help="problems (default: all)")
    ap.add_argument("--cap-s", type=float, default=120.0, help="wall-clock cap of one run, s (killed past it)")
    ap.add_argument("--json", type=Path, default=ROOT / "results" / "bench" / "refinement_robustness.json")
    ap.add_argument("--markdown", type=Path, default=ROOT / "results" / "bench" / "refinement_robustness.md")
    ap.add_argument("--notes", type=Path, default=None, help="markdown put after the summary (findings)")
    ap.add_argument("--table-only", action="store_true", help="run nothing: write --markdown from the rows in --json")
    args = ap.parse_args()
    if args.one:
        print(MARK + json.dumps(one(args.one[0], float(args.one[1]))), flush=True)
        return
    order = _names()
    names = args.only or order
    unknown = sorted(set(names) - set(order))
    if unknown:
        ap.error(f"unknown problem(s) {unknown}; known: {', '.join(order)}")
    rows = json.loads(args.json.read_text()) if args.json.exists() else []
    notes = args.notes.read_text() if args.notes else ""
    if args.table_only:
        write(rows, args.markdown, sys.argv[1:], order, notes)
        return
    for tol in args.tolerances:
        for name in names:
            row = run(name, tol, args.cap_s)
            rows = [r for r in rows if (r["problem"], r["tolerance"]) != (name, tol)] + [row]
            print(f"{name:32s} {tol:g} {row['outcome']:14s} {row.get('points', '')!s:>6} pts "
                  f"{_g(row.get('cpu_s'), '.1f')} s CPU {_g(row.get('wall_s', row.get('process_wall_s')), '.1f')} s wall  "
                  f"{(row.get('message') or row.get('error') or '')[:150]}", flush=True)
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(rows, indent=1))
            write(rows, args.markdown, sys.argv[1:], order, notes)


if __name__ == "__main__":
    main()
