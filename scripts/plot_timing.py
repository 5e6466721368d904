"""Whole-process cost of plotting (issue 14): wall and CPU time of ``ocp-constraints gait`` on the gait2354
and JW trials and of ``simulate whirling``, with plots and report.html and with ``--no-plots``.

Each command runs ``--runs`` times (default 3) as a fresh process into a new temporary ``--out``; the
table gives medians. CPU is user + system time of the process and every child it waited for
(``resource.getrusage(RUSAGE_CHILDREN)``), the same as ``/usr/bin/time``. The plots are timed twice:
by default (figures shared with a forked second process on a machine with 2+ CPUs,
``ocp_constraints/output/forked.py``) and in one process (``OCP_OUTPUT_PROCESSES=1``); the fork
pays only when a second core is idle. One untimed ``--no-plots``
run per command first fills the model cache (``~/.cache/ocp_constraints``), so the gait rows are
"model cache warm" as in the README. On a loaded machine the wall time is several times the CPU time;
the load average is printed with the table.

    python scripts/plot_timing.py [--runs 3] [--only gait2354 jw whirling] [--markdown PATH] [--baseline DIR]

``--baseline DIR``: also time the same commands with the package from ``DIR`` (``PYTHONPATH=DIR``, e.g. an
earlier commit: ``git archive <commit> ocp_constraints | tar -x -C DIR``), interleaved run by run with the
working tree's, so that both see the same load. The untimed first run may start a background compile of the
gait model's frame function (``--compiled auto``); the timed runs start once it has finished.
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
DATA = ROOT.parent / "shared" / "data"
G = DATA / "opensim-gait2354-subject01"
J = DATA / "grand-challenge-knee-jw"
COMMANDS = {
    "gait2354": ["gait", "--model", G / "subject01_simbody.osim", "--motion", G / "subject01_walk1_ik.mot",
                 "--grf", G / "subject01_walk1_grf.mot"],
    "jw": ["gait", "--model", J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim",
           "--motion", J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat",
           "--grf", J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat"],
    "whirling": ["simulate", "whirling"],
}


def _wait_for_background_compiles(timeout: float = 600.0) -> None:
    """Until no compile lock is left in the cache (a background compile would share the CPU with the timing)."""
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or os.path.join(os.path.expanduser("~"), ".cache")
    folder = Path(base) / "ocp_constraints"
    w = time.perf_counter()
    while list(folder.glob("*.lock")) and time.perf_counter() - w < timeout:
        time.sleep(0.2)


def run_once(cmd: list[str], processes: str | None = None, source: Path | None = None) -> tuple[float, float, int]:
    """(wall s, CPU s of the process and its children, number of PNG files) of one fresh process;
    ``processes``: ``OCP_OUTPUT_PROCESSES`` (None: the default, a forked second drawer on 2+ CPUs);
    ``source``: a folder holding another ``ocp_constraints`` to run instead (``PYTHONPATH``)."""
    exe = str(Path(sys.executable).with_name("ocp-constraints"))
    env = {**os.environ, "MPLBACKEND": "Agg"}
    if source is not None:
        env["PYTHONPATH"] = str(source)
    env.pop("OCP_OUTPUT_PROCESSES", None)
    if processes is not None:
        env["OCP_OUTPUT_PROCESSES"] = processes
    with tempfile.TemporaryDirectory(prefix="plot_timing_") as out:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        w0 = time.perf_counter()
        proc = subprocess.run([exe, *map(str, cmd), "--out", out], env=env, capture_output=True, text=True)
        wall = time.perf_counter() - w0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if proc.returncode != 0:
            raise SystemExit(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
        pngs = len(list(Path(out).glob("*.png")))
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, pngs


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--only", nargs="*", choices=sorted(COMMANDS), default=list(COMMANDS))
    p.add_argument("--markdown", type=Path, default=None, help="also write the table to this file")
    p.add_argument("--baseline", type=Path, default=None,
                   help="folder with another ocp_constraints (e.g. an earlier commit) timed interleaved with this one")
    a = p.parse_args()
    sources = [("", None)] + ([(f" [baseline {a.baseline}]", a.baseline.resolve())] if a.baseline else [])
    lines = ["| command | plots | wall, median | CPU (user + sys), median | PNG files | runs |", "|---|---|---:|---:|---:|---:|"]
    print("\n".join(lines), flush=True)
    for name in a.only:
        cmd = COMMANDS[name]
        for _, source in sources:
            run_once([*cmd, "--no-plots"], source=source)     # untimed: fills the model cache
        _wait_for_background_compiles()
        for label, extra, procs in (("plots + report.html", [], None),
                                    ("plots, one process (`OCP_OUTPUT_PROCESSES=1`)", [], "1"),
                                    ("--no-plots", ["--no-plots"], None)):
            rows: dict[str, list] = {tag: [] for tag, _ in sources}
            for _ in range(a.runs):                  # interleaved: both codes see the same load
                for tag, source in sources:
                    rows[tag].append(run_once([*cmd, *extra], procs, source))
            for tag, _ in sources:
                r = rows[tag]
                lines.append(f"| `{' '.join(cmd[:1] + [name] if cmd[0] == 'gait' else cmd)}`{tag} | {label} | "
                             f"{statistics.median(x[0] for x in r):.2f} s | {statistics.median(x[1] for x in r):.2f} s | "
                             f"{r[0][2]} | {a.runs} |")
                print(lines[-1], flush=True)
    load = os.getloadavg()
    lines.append(f"\nload average at the end: {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on {os.cpu_count()} CPUs")
    print(lines[-1])
    if a.markdown:
        a.markdown.parent.mkdir(parents=True, exist_ok=True)
        a.markdown.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
