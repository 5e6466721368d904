"""The whole ``knee`` command at an earlier commit and now, run alternately, and whether its loads are the same.

    python scripts/knee_speed_before_after.py [--rev a49e87c] [--runs 3] [--method collocation]
        [--drawing-process auto|on|off] [--now-rev REV] [--compile none|before|now|both]

``--rev``'s ``ocp_constraints`` is taken with ``git archive`` into a temporary folder and put first on
``PYTHONPATH`` (this working tree's package for "now"); both run as separate processes as
``knee_collocation_command.py`` runs the command (README's ngait_og5 arguments, ``OPENBLAS_NUM_THREADS=1`` before
NumPy loads, as the ``ocp-constraints`` entry point's ``cli_knee``), one warm-up run each first (the gait
functions' disk cache is keyed by the source of the modules that build them, and a new key builds them once),
then "before" and "now" alternately so that a change of the machine's load hits both alike. Per run: wall
seconds, CPU seconds (user + system of the command and its drawing process), the load average before it, and the
steps of summary.json (inverse dynamics, build, solve); then the medians, and the largest difference between the
two versions' loads.csv (every column, every frame): the loads must be the same.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from knee_collocation_command import ARGS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CHILD = ("import os, sys; os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); "
         "import ocp_constraints; assert ocp_constraints.__file__.startswith(sys.argv[1]), ocp_constraints.__file__; "
         "from ocp_constraints.cli.main import main; sys.exit(main(sys.argv[2:]))")


def run(tree: Path, method: str, out: Path, drawing: str) -> tuple[float, float]:
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(tree)}
    if drawing != "auto":
        env["OCP_OUTPUT_PROCESSES"] = "2" if drawing == "on" else "1"
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    subprocess.run([sys.executable, "-c", CHILD, str(tree), "knee", *ARGS, "--method", method, "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime - usage.ru_utime + after.ru_stime - usage.ru_stime


def loads(path: Path) -> dict[str, list[float]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    return {h: [float(r[i]) for r in rows[1:]] for i, h in enumerate(head)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rev", default="a49e87c")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--method", default="collocation")
    ap.add_argument("--drawing-process", choices=("auto", "on", "off"), default="auto")
    ap.add_argument("--now-rev", default=None, help="'now' from this commit too (default: the working tree)")
    ap.add_argument("--compile", choices=("none", "before", "now", "both"), default="none",
                    help="compile that copy's modules to bytecode first (python -m compileall), as an installed "
                         "package has them; with PYTHONDONTWRITEBYTECODE=1 the working tree has none")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        trees = {}
        for name, rev in ((f"before ({a.rev})", a.rev), (f"now ({a.now_rev})" if a.now_rev else "now", a.now_rev)):
            if rev is None:
                trees[name] = ROOT
                continue
            tree = Path(tmp) / f"tree{len(trees)}"
            tree.mkdir()
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "ocp_constraints"], check=True,
                                     capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
            if a.compile in ("both", "before" if not trees else "now"):
                subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree / "ocp_constraints")], check=True)
                trees[f"{name}, bytecode"] = tree
            else:
                trees[name] = tree
        for name, tree in trees.items():          # warm-up: the disk caches of each version
            run(tree, a.method, Path(tmp) / f"warm{list(trees).index(name)}", a.drawing_process)
        rows: dict[str, list] = {name: [] for name in trees}
        for i in range(a.runs):
            for name, tree in trees.items():
                out = Path(tmp) / f"out{list(trees).index(name)}_{i}"
                load = os.getloadavg()[0]
                wall, cpu = run(tree, a.method, out, a.drawing_process)
                steps = json.loads((out / "summary.json").read_text())["wall_time_s"]
                rows[name].append((wall, cpu, out))
                print(f"{name:>26} run {i + 1}: {wall:.2f} s wall, {cpu:.2f} s CPU, load before {load:.2f}; summary: "
                      + ", ".join(f"{k} {v:.2f}" for k, v in steps.items() if v is not None), flush=True)
        for name, r in rows.items():
            walls, cpus = sorted(x[0] for x in r), sorted(x[1] for x in r)
            print(f"{name:>26} median of {a.runs}: {walls[len(walls) // 2]:.2f} s wall, {cpus[len(cpus) // 2]:.2f} s CPU")
        (b_out, n_out) = (rows[name][0][2] for name in trees)
        lb, ln = loads(b_out / "loads.csv"), loads(n_out / "loads.csv")
        if set(lb) != set(ln):
            print(f"loads.csv columns differ: {sorted(set(lb) ^ set(ln))}")
        worst = max(max(abs(x - y) for x, y in zip(lb[k], ln[k])) for k in set(lb) & set(ln))
        print(f"largest difference of any loads.csv value (before vs now): {worst:.3g}")


if __name__ == "__main__":
    main()
