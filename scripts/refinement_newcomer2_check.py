"""A second newcomer's check of accuracy on request: ``problem.solve(tolerance=TOL)`` on the problems of
scripts/refinement_newcomer2_problems.py (LQ with layers, a pendulum in gravity on two horizons, a terminal cost),
each run in its own process, its true errors against the independent reference, as a markdown table.

    python scripts/refinement_newcomer2_check.py [--runs PROBLEM:TOL ...] [--out results/bench/refinement_newcomer2.md]
                                                 [--cap-s 200] [--jobs 2]
    python scripts/refinement_newcomer2_check.py --one PROBLEM:TOL      # one run in this process, its record as JSON

Default runs: lq, lq2, lq3, lq4, pend and mayer at 1e-3 1e-4 1e-6 1e-8; pend2 at 1e-3 3e-4 1e-4 1e-5 1e-6 1e-8.
Each run is a subprocess capped at --cap-s seconds of CPU (RLIMIT_CPU) and of wall time (timeout), at most --jobs at
once. The CPU column is time.process_time around solve() only (reference and measurement excluded).

True errors, on 2001 equally spaced points of the horizon plus the solution's own points: states absolute (max over
every coordinate and speed), inputs and multipliers relative to the reference's largest |value| in the group, t = 0
left out for those (Radau has no collocation point there). Gated by the tolerance: states and multipliers; the inputs
are reported, not gated.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import datetime
import json
import os
import re
import resource
import shlex
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from refinement_newcomer2_problems import PROBLEMS, build, reference  # noqa: E402

QUANTITIES = ("states", "inputs", "multipliers")
GATED = ("states", "multipliers")
DEFAULT_RUNS = ([f"{p}:{t}" for p in ("lq", "lq2", "lq3", "lq4", "pend") for t in ("1e-3", "1e-4", "1e-6", "1e-8")]
                + [f"pend2:{t}" for t in ("1e-3", "3e-4", "1e-4", "1e-5", "1e-6", "1e-8")]
                + [f"mayer:{t}" for t in ("1e-3", "1e-4", "1e-6", "1e-8")])
PLAIN_MESSAGE = re.compile(r"estimated error at most \S+ after \d+ refinements? \(\d+ intervals, \d+ points\)")


# ----------------------------------------------------------------------------------------------- one run
def worst(sol, refs, ts, keep=None):
    """max over names and times of |sol - ref| (where keep), with the time and name where it sits."""
    best = (0.0, None, None)
    for name, ref in refs.items():
        d = np.abs(np.asarray(sol.polynomial(name, ts)) - ref)
        if keep is not None:
            d = np.where(keep, d, 0.0)
        k = int(np.argmax(d))
        if d[k] > best[0]:
            best = (float(d[k]), float(ts[k]), name)
    return best


def true_errors(sol, f, T):
    # the solution's own points join the grid: a kink's or a layer's worst error can fall between grid points
    frac = np.unique(np.concatenate([np.linspace(0.0, 1.0, 2001), np.asarray(sol.t, float) / T]))
    ts = np.clip(frac * T, 0.0, T)
    groups = dict(zip(QUANTITIES, f(ts)))
    out = {}
    for q, refs in groups.items():
        if q == "states":
            err, at, name = worst(sol, refs, ts)
        else:
            scale = max(float(np.max(np.abs(r))) for r in refs.values())
            err, at, name = worst(sol, refs, ts, keep=frac > 0)
            err /= scale
        out[q], out[q + "_where"] = err, [at, name]
    return out


def run_one(problem: str, tol: float) -> dict:
    import ocp_constraints as oc

    ocp = build(problem)
    c0, w0 = time.process_time(), time.perf_counter()
    sol = ocp.solve(tolerance=tol)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    mr = sol.mesh_refinement
    T, objective_ref, f = reference(problem)
    true = true_errors(sol, f, T)
    est = {q: (float(v) if v is not None else None) for q, v in (mr.get("estimate") or {}).items()}
    return {"problem": problem, "tol": tol, "met": bool(mr.get("met")), "message": str(mr.get("message")),
            "refinements": mr.get("refinements"), "intervals": len(mr["mesh"]) - 1, "points": len(sol.t),
            "estimate": est, "true": true,
            "ratio": {q: (true[q] / est[q] if est.get(q) else None) for q in QUANTITIES},
            "cpu_s": cpu, "wall_s": wall, "status": sol.status, "objective": float(sol.objective),
            "objective_ref": float(objective_ref), "objective_diff": float(sol.objective) - float(objective_ref),
            "library": oc.__file__}


# ----------------------------------------------------------------------------------------------- the set
def launch(spec: str, cap_s: float) -> dict:
    """One run in a fresh process (no state shared between runs), capped in CPU and wall time."""
    problem, tol = spec.split(":")
    base = {"problem": problem, "tol_text": tol}

    def cpu_cap():      # a solve that spins stops here instead of holding a job slot for ever
        resource.setrlimit(resource.RLIMIT_CPU, (int(cap_s), int(cap_s) + 5))
    try:
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--one", spec], capture_output=True,
                             text=True, timeout=cap_s, preexec_fn=cpu_cap)
    except subprocess.TimeoutExpired:
        return {**base, "over_cap": f"wall time over {cap_s:g} s"}
    if out.returncode in (-24, -9):      # SIGXCPU at the soft limit, SIGKILL at the hard one
        return {**base, "over_cap": f"CPU time over {cap_s:g} s (signal {-out.returncode})"}
    try:
        rec = json.loads(out.stdout.strip().splitlines()[-1])
    except (json.JSONDecodeError, IndexError):
        tail = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return {**base, "error": f"exit {out.returncode}: {tail[:200]}"}
    rec.update(base)
    if rec["cpu_s"] > cap_s:
        rec["over_cap"] = f"solve CPU {rec['cpu_s']:.1f} s over {cap_s:g} s"
    return rec


def breaches(r: dict) -> list[str]:
    head = f"{r['problem']} {r['tol_text']}"
    if "error" in r:
        return [f"{head}: error ({r['error']})"]
    if "estimate" not in r:
        return [f"{head}: over the cap ({r['over_cap']})"]
    out = [f"{head}: over the cap ({r['over_cap']})"] if "over_cap" in r else []
    tol, t, e, q = r["tol"], r["true"], r["estimate"], r["ratio"]
    for k in QUANTITIES:
        where = f"at t = {t[k + '_where'][0]:.4g} s in {t[k + '_where'][1]}"
        if r["met"] and t[k] > tol:
            gate = "gated" if k in GATED else "inputs are reported, not gated"
            out.append(f"{head}: met, but the true {k} error {t[k]:.2e} > tol {tol:g} ({gate}; {where})")
        if q[k] is not None and q[k] > 1:
            out.append(f"{head}: {k} true {t[k]:.2e} > estimate {e[k]:.2e} (ratio {q[k]:.2f}; {where})")
        if q[k] is not None and q[k] < 0.1:
            out.append(f"{head}: {k} true {t[k]:.2e} < estimate {e[k]:.2e} / 10 (ratio {q[k]:.2g})")
    return out


def triple(values: dict, fmt: str) -> str:
    return " / ".join("-" if values.get(k) is None else format(values[k], fmt) for k in QUANTITIES)


def table(records: list[dict]) -> list[str]:
    lines = ["| problem | tol | met | refinements | intervals / points | estimate s / i / m | true s / i / m "
             "| true/estimate s / i / m | CPU s (solve) | objective - reference |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        if "estimate" not in r:
            lines.append(f"| {r['problem']} | {r['tol_text']} | {'error' if 'error' in r else 'over cap'} "
                         f"| | | | | | | |")
            continue
        lines.append(f"| {r['problem']} | {r['tol_text']} | {'yes' if r['met'] else 'no'} | {r['refinements']} "
                     f"| {r['intervals']} / {r['points']} | {triple(r['estimate'], '.1e')} "
                     f"| {triple(r['true'], '.1e')} "
                     f"| {triple(r['ratio'], '.2g')} | {r['cpu_s']:.2f} | {r['objective_diff']:.1e} |")
    return lines


def report(records: list[dict], command: str, started: str, head: str, load: tuple) -> str:
    done = [r for r in records if "estimate" in r]
    met = sum(r["met"] for r in done)
    lines = ["# Accuracy on request: a second newcomer's problems", "",
             f"{len(records)} runs, {met} met, {len(done) - met} not met, {len(records) - len(done)} without a "
             f"result. Columns s / i / m: states (absolute), inputs and multipliers (relative to the reference's "
             f"largest value); gated: states and multipliers. CPU: solve() only. Objective: the library's minus "
             f"the reference's (mayer: the full J, terminal term included).", "", *table(records), "",
             "## Breaches", ""]
    found = [b for r in records for b in breaches(r)]
    lines += [f"- {b}" for b in found] or ["- none"]
    odd = [r for r in done if not PLAIN_MESSAGE.fullmatch(r["message"])]
    if odd:
        lines += ["", "## Messages other than the plain 'estimated error at most TOL after N refinements (...)'", ""]
        lines += [f"- {r['problem']} {r['tol_text']}: {r['message']}" for r in odd]
    library = sorted({r["library"] for r in done})
    lines += ["", f"Command: `{command}`; started {started} (UTC); git HEAD {head}; load average at start "
              f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; library {', '.join(library)}.", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", nargs="+", default=DEFAULT_RUNS, metavar="PROBLEM:TOL")
    parser.add_argument("--out", default=os.path.join(HERE, "..", "results", "bench", "refinement_newcomer2.md"))
    parser.add_argument("--cap-s", type=float, default=200.0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--one", metavar="PROBLEM:TOL", help="one run in this process; prints its record as JSON")
    args = parser.parse_args()
    if args.one:
        problem, tol = args.one.split(":")
        print(json.dumps(run_one(problem, float(tol)), default=str))
        return
    for spec in args.runs:      # refuse a typo before an hour of runs, not at its turn
        problem, _, tol = spec.partition(":")
        if problem not in PROBLEMS or not tol:
            parser.error(f"run {spec!r}: PROBLEM:TOL with PROBLEM one of {', '.join(PROBLEMS)}")
        float(tol)
    command = shlex.join(["python", *sys.argv])
    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")
    head = subprocess.run(["git", "-C", os.path.dirname(HERE), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip() or "unknown"
    load = os.getloadavg()
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        records = list(pool.map(lambda spec: launch(spec, args.cap_s), args.runs))
    text = report(records, command, started, head, load)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as fh:
        fh.write(text)
    print(text)


if __name__ == "__main__":
    main()
