"""The whole ``knee --method collocation`` command on ngait_og5: wall and CPU seconds, and where they go.

    python scripts/knee_collocation_command.py [--runs 3] [--method collocation] [--timeline]

Runs ``ocp-constraints knee $A --method M --out DIR`` (``$A``: the README's ngait_og5 arguments) ``--runs`` times
as a separate process, as preregistration C17 times it: wall seconds from start to exit, CPU seconds (user +
system, the command and its drawing process: ``resource.getrusage(RUSAGE_CHILDREN)``), the load average before
each run, and the steps' wall seconds from its summary.json (inverse dynamics, build, solve, total of
``run_knee``). ``--before``: the same command with IPOPT's own values of the options that
``knee_collocation.KKT_OPTIONS`` sets (the code before them), for a before/after pair in the same conditions.
``--timeline``: one more run in this process with the time since the interpreter started at which
each step begins and ends (imports, ``run_knee``'s steps, writing the results and figure), to find the fixed
costs outside the solve. ``--casadi-blas-threads N``: the command with CasADi's OpenBLAS (the BLAS MUMPS calls)
set to N threads after it loads (NumPy's stays at one), to measure a second core in the KKT factorizations.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIAL = J / "reducepoly_subject_GC"
ARGS = ["--model", str(MODEL), "--motion", str(TRIAL / "IK" / "IK_ngait_og5.mat"),
        "--grf", str(TRIAL / "GRF" / "GRF_ngait_og5.mat"), "--measured", str(TRIAL / "KCF" / "KCF_ngait_og5.mat")]
START = time.perf_counter()


# IPOPT's own values of the options knee_collocation.KKT_OPTIONS sets: the command as it was before them
IPOPT_DEFAULTS = {"ipopt.mumps_mem_percent": 1000, "ipopt.mumps_permuting_scaling": 7, "ipopt.mumps_pivot_order": 7,
                  "ipopt.min_refinement_steps": 1}
BEFORE = ("import os, sys; os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); "   # as cli_knee, before NumPy loads
          "import ocp_constraints.biomech.knee_collocation as kc; kc.KKT_OPTIONS.clear(); "
          f"kc.KKT_OPTIONS.update({IPOPT_DEFAULTS!r}); from ocp_constraints.cli.main import main; "
          "sys.exit(main(sys.argv[1:]))")


# CasADi's own OpenBLAS (MUMPS's dense kernels) with N threads, NumPy's left at one as cli_knee sets it: a
# measurement of whether a second core pays in the KKT factorizations (not what the command does)
CASADI_BLAS = ("import os, sys, ctypes; os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); import casadi; "
               "from pathlib import Path; ctypes.CDLL(str(Path(casadi.__file__).parent / "
               "'libcasadi-tp-openblas.so.0')).openblas_set_num_threads({n}); "
               "from ocp_constraints.cli.main import main; sys.exit(main(sys.argv[1:]))")


def command(method: str, out: Path, before: bool = False, casadi_blas_threads: int | None = None) -> list[str]:
    """The knee command line; ``before``: the same through ``python -c`` with IPOPT's defaults for KKT_OPTIONS;
    ``casadi_blas_threads``: through ``python -c`` with CasADi's OpenBLAS set to that many threads."""
    if before:
        return [sys.executable, "-c", BEFORE, "knee", *ARGS, "--method", method, "--out", str(out)]
    if casadi_blas_threads:
        return [sys.executable, "-c", CASADI_BLAS.format(n=int(casadi_blas_threads)), "knee", *ARGS,
                "--method", method, "--out", str(out)]
    exe = Path(sys.executable).parent / "ocp-constraints"
    return [str(exe), "knee", *ARGS, "--method", method, "--out", str(out)]


def timed_runs(method: str, runs: int, before: bool = False, casadi_blas_threads: int | None = None) -> None:
    rows = []
    for i in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            load = os.getloadavg()[0]
            usage = resource.getrusage(resource.RUSAGE_CHILDREN)
            wall = time.perf_counter()
            subprocess.run(command(method, Path(tmp) / "out", before, casadi_blas_threads), check=True, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, env={**os.environ, "MPLBACKEND": "Agg"})
            wall = time.perf_counter() - wall
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            user, system = after.ru_utime - usage.ru_utime, after.ru_stime - usage.ru_stime
            steps = json.loads((Path(tmp) / "out" / "summary.json").read_text())["wall_time_s"]
        rows.append((wall, user + system))
        print(f"run {i + 1}: {wall:.2f} s wall, {user:.2f} + {system:.2f} s CPU (user + sys), load before {load:.2f}; "
              f"summary: " + ", ".join(f"{k} {v:.2f}" for k, v in steps.items() if v is not None), flush=True)
    walls, cpus = sorted(r[0] for r in rows), sorted(r[1] for r in rows)
    print(f"median of {runs}: {walls[len(walls) // 2]:.2f} s wall, {cpus[len(cpus) // 2]:.2f} s CPU")


def timeline(method: str) -> None:
    """One run in this process, the steps' start and end since the interpreter started (``time.perf_counter``)."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    marks = []

    def mark(name):
        marks.append((name, time.perf_counter() - START, time.process_time()))

    mark("script start (imports of this script only)")
    import importlib

    cli_main = importlib.import_module("ocp_constraints.cli.main")
    import ocp_constraints.biomech.knee_pipeline as kp
    mark("ocp_constraints CLI and knee pipeline imported")

    def wrap(module, name):
        real = getattr(module, name)

        def timed(*a, **k):
            mark(f"{name} begins")
            try:
                return real(*a, **k)
            finally:
                mark(f"{name} ends")
        setattr(module, name, timed)
        return real

    real_run, real_write = wrap(kp, "run_knee"), wrap(kp, "write_knee_results")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            cli_main.main(["knee", *ARGS, "--method", method, "--out", str(Path(tmp) / "out")])
            steps = json.loads((Path(tmp) / "out" / "summary.json").read_text())["wall_time_s"]
    finally:
        kp.run_knee, kp.write_knee_results = real_run, real_write
    mark("command returned")
    for name, t, cpu in marks:
        print(f"{t:7.2f} s wall, {cpu:6.2f} s CPU: {name}")
    print("run_knee steps (wall, summary.json):", ", ".join(f"{k} {v:.2f}" for k, v in steps.items() if v is not None))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--method", default="collocation")
    ap.add_argument("--timeline", action="store_true")
    ap.add_argument("--before", action="store_true",
                    help="the collocation with IPOPT's defaults instead of knee_collocation.KKT_OPTIONS (the code before)")
    ap.add_argument("--casadi-blas-threads", type=int, default=None, metavar="N",
                    help="CasADi's OpenBLAS (MUMPS's dense kernels) with N threads, NumPy's with one (a measurement)")
    a = ap.parse_args()
    if a.runs:
        timed_runs(a.method, a.runs, a.before, a.casadi_blas_threads)
    if a.timeline:
        timeline(a.method)
