"""The whole ``knee`` command's wall time split at the process's edges: start-up, ``main``, exit.

    python scripts/knee_command_phases.py [--runs 3] [--method collocation] [--drawing-process auto|on|off]

Runs the command as ``knee_collocation_command.py`` does (README's ngait_og5 arguments, a separate process),
through ``python -c`` so that the child stamps (``time.time()``, the same clock as this process) when its
interpreter is up, when ``main`` begins and returns, and (``atexit``) when Python starts to exit; this process
stamps the spawn and the child's end. The four intervals: interpreter start-up (spawn to first line),
``main`` (imports, run_knee, writing, the figure), the interpreter's exit (atexit to the end: module teardown,
the drawing process's end), and CPU seconds (user + system, the command and its drawing process).
``--drawing-process on``: ``OCP_OUTPUT_PROCESSES=2`` (the figure drawn by the forked child, as on a quiet
machine, whatever the load); ``off``: ``OCP_OUTPUT_PROCESSES=1``; ``auto``: as the command decides.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from knee_collocation_command import ARGS  # noqa: E402

CHILD = ("import time; t0 = time.time(); import atexit, os, sys; "
         "os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); "     # as the ocp-constraints entry point's cli_knee
         "atexit.register(lambda: print('STAMP exit', repr(time.time()), file=sys.stderr, flush=True)); "
         "print('STAMP start', repr(t0), file=sys.stderr, flush=True); "
         "from ocp_constraints.cli.main import main; "
         "t1 = time.time(); code = main(sys.argv[1:]); "
         "print('STAMP main', repr(t1), repr(time.time()), file=sys.stderr, flush=True); sys.exit(code)")


def one(method: str, drawing: str) -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    if drawing != "auto":
        env["OCP_OUTPUT_PROCESSES"] = "2" if drawing == "on" else "1"
    with tempfile.TemporaryDirectory() as tmp:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        spawn = time.time()
        p = subprocess.run([sys.executable, "-c", CHILD, "knee", *ARGS, "--method", method, "--out", str(Path(tmp) / "o")],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, check=True)
        end = time.time()
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    stamps = {ln.split()[1]: [float(x) for x in ln.split()[2:]] for ln in p.stderr.splitlines() if ln.startswith("STAMP")}
    return {"start-up": stamps["start"][0] - spawn, "imports of cli.main": stamps["main"][0] - stamps["start"][0],
            "main": stamps["main"][1] - stamps["main"][0], "main to exit": stamps["exit"][0] - stamps["main"][1],
            "exit": end - stamps["exit"][0], "total": end - spawn,
            "cpu": after.ru_utime - usage.ru_utime + after.ru_stime - usage.ru_stime}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--method", default="collocation")
    ap.add_argument("--drawing-process", choices=("auto", "on", "off"), default="auto")
    a = ap.parse_args()
    rows = []
    for i in range(a.runs):
        load = os.getloadavg()[0]
        r = one(a.method, a.drawing_process)
        rows.append(r)
        print(f"run {i + 1} (load before {load:.2f}): " + ", ".join(f"{k} {v:.3f} s" for k, v in r.items()), flush=True)
    print(f"median of {a.runs}: " + ", ".join(f"{k} {sorted(r[k] for r in rows)[len(rows) // 2]:.3f} s" for k in rows[0]))
