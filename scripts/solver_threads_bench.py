"""IPOPT solves with CasADi's OpenBLAS on one thread (the library's default) against one thread per core.

    python scripts/solver_threads_bench.py [--runs 3] [--markdown FILE] [CASE ...]

A case is ``PROBLEM@TOLERANCE`` (``problem.solve(tolerance=...)``) or ``PROBLEM@radauDxN`` (a fixed mesh:
degree D, N intervals); problems are those of ``scripts/ocp_default_robustness.py``. Each solve runs in
its own process, the two settings alternately, and the table gives the medians of wall and CPU time of
build + solve. "One thread" is the library as it is (``ocp/solver_threads.py``); "all cores" sets
``OPENBLAS_NUM_THREADS`` to the core count, which the library leaves alone: OpenBLAS's own default.
Run it alone on the machine: a busy core inflates the threaded runs most.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = ["suite:quadrotor_load@1e-3", "scene:ball_socket.reach@1e-3", "suite:walker@1e-3", "newcomer:cart_pole@1e-3",
         "scene:pendulum.swing_up@radau6x20", "newcomer:cart_pole@radau3x1000"]
CHILD = """
import json, sys, time
sys.path.insert(0, {scripts!r})
import ocp_default_robustness as o
import ocp_constraints as oc
name, setting = sys.argv[1], sys.argv[2]
problem = o.PROBLEMS[name]()
cpu, wall = time.process_time(), time.perf_counter()
if setting.startswith("radau"):
    degree, intervals = setting[5:].split("x")
    sol, points = problem.solve(method=oc.Radau(int(intervals), degree=int(degree))), None
else:
    sol = problem.solve(tolerance=float(setting), progress=False)
    points = sol.mesh_refinement["history"][-1]["points"]
print(json.dumps({{"cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
                  "objective": float(sol.objective), "points": points}}))
"""
SETTINGS = {"one thread": {}, "all cores": {"OPENBLAS_NUM_THREADS": str(os.cpu_count() or 1)}}


def _run(case: str, extra_env: dict) -> dict:
    name, setting = case.split("@")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", CHILD.format(scripts=str(ROOT / "scripts")), name, setting],
                         env={**env, "MPLBACKEND": "Agg", **extra_env}, capture_output=True, text=True, cwd=ROOT)
    lines = [line for line in out.stdout.splitlines() if line.startswith("{")]
    if out.returncode != 0 or not lines:
        raise SystemExit(f"{case} failed ({extra_env or 'one thread'}): {out.stderr[-800:]}")
    return json.loads(lines[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", default=CASES)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args()
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    rows = ["| case | wall, one thread / all cores (s) | wall ratio | CPU, one thread / all cores (s) | same objective, same mesh |",
            "|---|---|---|---|---|"]
    for case in args.cases:
        runs = {s: [] for s in SETTINGS}
        for _ in range(args.runs):
            for setting, env in SETTINGS.items():
                runs[setting].append(_run(case, env))
        med = {s: {k: statistics.median(r[k] for r in rs) for k in ("wall", "cpu")} for s, rs in runs.items()}
        a, b = runs["one thread"][0], runs["all cores"][0]
        same = abs(a["objective"] - b["objective"]) <= 1e-9 * max(1.0, abs(a["objective"])) and a["points"] == b["points"]
        rows.append(f"| {case} | {med['one thread']['wall']:.2f} / {med['all cores']['wall']:.2f} | "
                    f"{med['all cores']['wall'] / med['one thread']['wall']:.2f} | "
                    f"{med['one thread']['cpu']:.2f} / {med['all cores']['cpu']:.2f} | {'yes' if same else 'NO'} |")
        print(rows[-1], flush=True)
    text = (f"# IPOPT's OpenBLAS: one thread against all cores\n\n`python scripts/solver_threads_bench.py"
            f"{' ' + ' '.join(sys.argv[1:]) if sys.argv[1:] else ''}` ({started}, {os.cpu_count()} cores, load average "
            f"{os.getloadavg()[0]:.1f} at the end); medians of {args.runs} runs each, alternated, each in its own process.\n\n"
            + "\n".join(rows) + "\n")
    if args.markdown:
        args.markdown.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
