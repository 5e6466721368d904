"""Issue 14's must-shows for forward simulation and start-up, measured side by side in one run.

    python scripts/forward_speed.py [--runs 3] [--startup-runs 5] [--scenes pendulum sliding_disk]
                                    [--out results/bench/forward_speed.md] [--no-whole-process]

1. Forward duel (:mod:`ocp_constraints.bench.forward_duel`): the pendulum against Pinocchio's ABA +
   SciPy's DOP853, the sliding disk against sympy's LagrangesMethod + DOP853; every setting run
   ``--runs`` times interleaved, medians of wall and CPU time, in-process and whole process; per
   peer tolerance our cheapest setting at equal or better error and the ratios ours / theirs.
2. Start-up: ``ocp-constraints --help`` and ``ocp-constraints simulate whirling --no-plots``,
   ``--startup-runs`` fresh processes each, medians of wall and CPU time (bytecode cache on, as
   after a user's first run; see :func:`ocp_constraints.bench.forward_duel.child_environment`),
   with the targets of the issue (0.3 s and 1 s of wall time).

The machine's load average is printed with each table: on a shared machine wall times are
inflated (CPU times much less), so the ratios of interleaved runs are the comparable numbers.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import time
from pathlib import Path

from ocp_constraints.bench.forward_duel import child_environment, duel_markdown, forward_duel, run_child

STARTUP_TARGETS = {"--help": 0.3, "simulate whirling --no-plots": 1.0}


def command() -> list[str]:
    """The ``ocp-constraints`` console script beside this Python, else ``python -m ocp_constraints``."""
    exe = Path(sys.executable).with_name("ocp-constraints")
    found = str(exe) if exe.is_file() else shutil.which("ocp-constraints")
    return [found] if found else [sys.executable, "-m", "ocp_constraints"]


def startup_times(runs: int = 5) -> list[dict]:
    """Median wall and CPU seconds of each start-up command over ``runs`` fresh processes (after one
    untimed run that writes the bytecode cache)."""
    env = child_environment()
    rows = []
    for args, target in STARTUP_TARGETS.items():
        argv = command() + args.split()
        run_child(argv, env)
        walls, cpus = zip(*(run_child(argv, env) for _ in range(runs)))
        rows.append({"command": "ocp-constraints " + args, "wall": statistics.median(walls),
                     "cpu": statistics.median(cpus), "target": target, "runs": runs})
    return rows


def startup_markdown(rows: list[dict]) -> str:
    load = os.getloadavg()[0]
    lines = [f"Start-up, medians of {rows[0]['runs']} fresh processes (load average {load:.1f} on {os.cpu_count()} cores)",
             "", "| command | wall s | CPU s | target (wall) |", "|---|---|---|---|"]
    lines += [f"| `{r['command']}` | {r['wall']:.3f} | {r['cpu']:.3f} | {r['target']:g} s |" for r in rows]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="interleaved runs per duel setting (median; default 3)")
    ap.add_argument("--startup-runs", type=int, default=5, help="processes per start-up command (median; default 5)")
    ap.add_argument("--scenes", nargs="*", default=["pendulum", "sliding_disk"])
    ap.add_argument("--out", default=None, help="also write the tables to this Markdown file")
    ap.add_argument("--no-whole-process", action="store_true", help="in-process duel only (faster)")
    args = ap.parse_args()
    started = time.perf_counter()
    parts = [startup_markdown(startup_times(args.startup_runs))]
    print(parts[0], flush=True)
    for scene in args.scenes:
        text = duel_markdown(forward_duel(scene, runs=args.runs, whole_process=not args.no_whole_process,
                                          log=lambda m: print(m, file=sys.stderr, flush=True)))
        print(text, flush=True)
        parts.append(text)
    parts.append(f"(python scripts/forward_speed.py --runs {args.runs} --startup-runs {args.startup_runs}: "
                 f"{time.perf_counter() - started:.0f} s in all)\n")
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text("\n".join(parts))


if __name__ == "__main__":
    main()
