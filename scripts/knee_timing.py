"""Timings of the ``knee`` command on ngait_og5 (issue 15): whole command and its phases.

    python scripts/knee_timing.py            # 3 runs of the README's knee command (subprocess): median wall, CPU
    python scripts/knee_timing.py --runs 5 --no-plots
    python scripts/knee_timing.py --phases   # one run in-process: wall and CPU of each phase
    python scripts/knee_timing.py --static --runs 5   # the static optimisation alone, medians

CPU is user + system time of the command (``resource.getrusage``), all its processes together,
and of its main process alone (the figure process imports matplotlib beside it on the other
core). The machine's load average is printed with each run: on a shared machine the wall time
is not the program's.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
TRIAL = DATA / "reducepoly_subject_GC"
MODEL = DATA / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"


def knee_args(trial: str = "ngait_og5") -> list[str]:
    return ["--model", str(MODEL), "--motion", str(TRIAL / "IK" / f"IK_{trial}.mat"),
            "--grf", str(TRIAL / "GRF" / f"GRF_{trial}.mat"), "--measured", str(TRIAL / "KCF" / f"KCF_{trial}.mat")]


# the command's own process reports its CPU apart from its figure process's (os.times)
WRAPPER = """import os, sys
from ocp_constraints.cli import main
rc = main(sys.argv[1:])
t = os.times()
print("CPU", t.user + t.system, t.children_user + t.children_system, file=sys.stderr)
sys.exit(rc)
"""


def run_command(extra: list[str]) -> tuple[float, float, float]:
    """Wall, CPU of all processes and CPU of the main process alone (s) of one ``knee`` run, fresh process."""
    with tempfile.TemporaryDirectory() as out:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        clock = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", WRAPPER, "knee", *knee_args(), "--out", out, *extra], check=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "MPLBACKEND": "Agg"})
        wall = time.perf_counter() - clock
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    own = float(next(line for line in done.stderr.splitlines() if line.startswith("CPU ")).split()[1])
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), own


def phases(plots: bool) -> None:
    """One in-process run, wall and CPU per phase."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("MPLBACKEND", "Agg")
    marks = [("start", time.perf_counter(), time.process_time())]

    def mark(name):
        marks.append((name, time.perf_counter(), time.process_time()))

    from ocp_constraints.biomech.knee_pipeline import run_knee, write_knee_results
    mark("imports")
    a = knee_args()
    run = run_knee(a[1], a[3], a[5], a[7])
    mark("run_knee")
    with tempfile.TemporaryDirectory() as out:
        write_knee_results(run, out, plots=plots)
    mark("write results" + (" + plots + report" if plots else ""))
    for (_, w0, c0), (name, w1, c1) in zip(marks, marks[1:]):
        print(f"{name:36s} {w1 - w0:6.2f} s wall {c1 - c0:6.2f} s CPU")
    print(f"{'total':36s} {marks[-1][1] - marks[0][1]:6.2f} s wall {marks[-1][2] - marks[0][2]:6.2f} s CPU")
    for name, v in run["step_times"].items():
        print(f"  {name:34s} {v['wall']:6.2f} s wall {v['cpu']:6.2f} s CPU")
    print("inverse dynamics (wall):", {k: round(v, 3) for k, v in run["gait"].timings.items()})
    print("static optimisation (wall):", {k: round(v, 3) for k, v in run["result"].timings.items()})


def static_only(runs: int) -> None:
    """The static optimisation alone, ``runs`` times on the cycle's inputs (captured from one run_knee)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    import ocp_constraints.biomech.knee_pipeline as pipeline
    from ocp_constraints.biomech.knee_static import solve_static

    captured = {}

    def capture(t, Qc, R, A, F0, **kw):
        captured.update(args=(t, Qc, R, A, F0), kw=kw)
        return solve_static(t, Qc, R, A, F0, **kw)

    pipeline.solve_static = capture
    a = knee_args()
    pipeline.run_knee(a[1], a[3], a[5], a[7], method="static")
    walls, cpus = [], []
    for i in range(runs):
        w, c = time.perf_counter(), time.process_time()
        res = solve_static(*captured["args"], **captured["kw"])
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
        print(f"run {i + 1}: {walls[-1]:.3f} s wall, {cpus[-1]:.3f} s CPU (build {res.timings['build']:.3f} s, "
              f"solve {res.timings['solve']:.3f} s wall; load average {os.getloadavg()[0]:.1f})")
    print(f"static optimisation of the cycle ({len(res.t)} frames): median of {runs}: "
          f"{statistics.median(walls):.3f} s wall, {statistics.median(cpus):.3f} s CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--no-plots", action="store_true")
    ap.add_argument("--phases", action="store_true")
    ap.add_argument("--static", action="store_true", help="the static optimisation alone, --runs times")
    args = ap.parse_args()
    if args.static:
        static_only(args.runs)
        return
    if args.phases:
        phases(not args.no_plots)
        return
    extra = ["--no-plots"] if args.no_plots else []
    walls, cpus, owns = [], [], []
    for i in range(args.runs):
        load = os.getloadavg()[0]
        w, c, o = run_command(extra)
        walls.append(w)
        cpus.append(c)
        owns.append(o)
        print(f"run {i + 1}: {w:.2f} s wall, {c:.2f} s CPU, of which {o:.2f} s in the main process "
              f"(load average {load:.1f})")
    print(f"knee{' --no-plots' if extra else ''}: median of {args.runs}: {statistics.median(walls):.2f} s wall, "
          f"{statistics.median(cpus):.2f} s CPU, {statistics.median(owns):.2f} s CPU in the main process")


if __name__ == "__main__":
    main()
