"""Timings of the ``gait`` command (issue 15's "Timings of gait and knee"): the README's JW ngait_og5 and
gait2354 subject01 arguments, each run a fresh process, figures and report included.

    python scripts/gait_command_timing.py [--runs 3] [--trials JW gait2354]

A first run of each trial fills the model-function cache and is not counted; then ``--runs`` runs, each
printed with its wall time, CPU (user + sys of the command and its drawing process, ``getrusage`` of the
children) and the load average, and their medians. The ``knee`` rows are ``scripts/knee_collocation_command.py``.
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

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
JW = DATA / "grand-challenge-knee-jw"
GAIT2354 = DATA / "opensim-gait2354-subject01"
TRIALS = {
    "JW": ["--model", str(JW / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"),
           "--motion", str(JW / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat"),
           "--grf", str(JW / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat")],
    "gait2354": ["--model", str(GAIT2354 / "subject01_simbody.osim"), "--motion", str(GAIT2354 / "subject01_walk1_ik.mot"),
                 "--grf", str(GAIT2354 / "subject01_walk1_grf.mot")],
}

COMMAND = "import sys; from ocp_constraints.cli import main; sys.exit(main(sys.argv[1:]))"


def run_once(args: list[str]) -> tuple[float, float]:
    """Wall and CPU (s, all processes of the command) of one ``gait`` run into a temporary folder."""
    with tempfile.TemporaryDirectory() as out:
        before, clock = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
        subprocess.run([sys.executable, "-c", COMMAND, "gait", *args, "--out", out], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env={**os.environ, "MPLBACKEND": "Agg"})
        wall, after = time.perf_counter() - clock, resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--trials", nargs="*", default=list(TRIALS), choices=list(TRIALS))
    a = ap.parse_args(argv)
    for name in a.trials:
        run_once(TRIALS[name])                   # fills the model-function cache
        walls, cpus = [], []
        for r in range(a.runs):
            wall, cpu = run_once(TRIALS[name])
            walls.append(wall)
            cpus.append(cpu)
            print(f"{name} run {r + 1}: {wall:.2f} s wall, {cpu:.2f} s CPU (load average {os.getloadavg()[0]:.2f})",
                  flush=True)
        print(f"{name}: median of {a.runs}: {statistics.median(walls):.2f} s wall ({min(walls):.2f}-{max(walls):.2f}), "
              f"{statistics.median(cpus):.2f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
