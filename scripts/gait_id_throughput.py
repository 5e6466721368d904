"""Inverse-dynamics throughput of the gait trials (issue 14): frames per second and whole `gait` commands.

    python scripts/gait_id_throughput.py [--runs 3] [--trials gait2354 jw] [--default-only] [--markdown PATH]

Every measurement runs in a fresh process, against a private cache folder (XDG_CACHE_HOME in a
temporary directory), so "cold" is really cold and nothing of the user's cache is used:

1. cold: no cache; the model's frame function is built from the .osim (and saved);
2. warm (VM): the serialized functions are read from the disk cache, CasADi's virtual machine;
3. compile: ``compiled="always"`` once (the C compiler's time is reported);
4. warm (C): the compiled library is loaded from the cache.

0. the default (``compiled="auto"``) on a cold cache: the first run (the virtual machine; it starts
   the background compile of the frame function), then, once that compile has finished (its wall
   time is reported), the second run (the compiled library loaded from the cache);

For each state: the load time (build / read / load / compile, CPU including the compiler's), the first evaluation over the trial's frames
and the median of 5 further evaluations (frames per second = frames / that time), all in-process
(wall and CPU), the trial 40 times over in one call (chunks of 512 frames), plus
``run_inverse_dynamics`` from files to results. Then the whole command
``ocp-constraints gait ... --no-plots`` (and once with plots) as a subprocess, warm caches, wall
and CPU (the children's user + system time). Medians of ``--runs`` runs (default 3).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TILE = 40          # copies of the trial in the large evaluation (JW: 9,880 frames)
DATA = ROOT.parent / "shared" / "data"
G = DATA / "opensim-gait2354-subject01"
J = DATA / "grand-challenge-knee-jw"
TRIALS = {
    "gait2354": [G / "subject01_simbody.osim", G / "subject01_walk1_ik.mot", G / "subject01_walk1_grf.mot"],
    "jw": [J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim",
           J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat", J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat"],
}


def child(trial: str, compiled: str) -> dict:
    """One fresh process: load the model's functions, evaluate the trial's frames, run the trial."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")        # as the CLI
    w0, c0 = time.perf_counter(), time.process_time()
    import numpy as np

    from ocp_constraints.biomech import gait_compiled
    from ocp_constraints.biomech.gait import run_inverse_dynamics
    from ocp_constraints.biomech.osim_model import load_osim

    imports = (time.perf_counter() - w0, time.process_time() - c0)
    model, motion, grf = TRIALS[trial]
    osim = load_osim(model)
    w, c, r = time.perf_counter(), time.process_time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    fns = gait_compiled.gait_functions(osim, compiled)
    r2 = resource.getrusage(resource.RUSAGE_CHILDREN)          # the C compiler runs as a child process
    load = (time.perf_counter() - w, time.process_time() - c + (r2.ru_utime - r.ru_utime) + (r2.ru_stime - r.ru_stime))
    source = fns.source
    result = run_inverse_dynamics(model, motion, grf, compiled=compiled)       # from files to results (functions in memory)
    N = len(result.t)
    S = result.states
    nb = len(fns.meta["bodies"])
    F = np.zeros((N, 3 * nb))
    M = np.zeros((N, 3 * nb))
    fext = S["fext"].reshape(N, nb, 6)
    xbar = S["q"].reshape(N, nb, 7)[:, :, :3]
    F[:] = fext[:, :, :3].reshape(N, -1)
    M[:] = (fext[:, :, 3:] + np.cross(xbar, fext[:, :, :3])).reshape(N, -1)       # moment about O again
    quat = S["q"].reshape(N, nb, 7)[:, :, 3:].reshape(N, -1)
    args = (S["p"].T, S["pdot"].T, S["pddot"].T, quat.T, F.T, M.T, result.t[None, :])
    fns._maps.clear()            # the first evaluation below makes the map, as a run does
    times = []
    for _ in range(6):
        w, c = time.perf_counter(), time.process_time()
        out = fns.evaluate(fns.frame, *args)
        times.append((time.perf_counter() - w, time.process_time() - c))
    same = float(np.max(np.abs(out[6].T - result.generalized_forces)))
    tiled = [np.tile(a, (1, TILE)) for a in args]          # the trial 40 times: chunks of 512 frames
    w, c = time.perf_counter(), time.process_time()
    big = fns.evaluate(fns.frame, *tiled)
    tile_s = (time.perf_counter() - w, time.process_time() - c)
    same = max(same, float(np.max(np.abs(big[6][:, -N:].T - result.generalized_forces))))
    warm = times[1:]
    w, c = time.perf_counter(), time.process_time()
    run_inverse_dynamics(model, motion, grf, compiled=compiled)
    again = (time.perf_counter() - w, time.process_time() - c)
    return {"trial": trial, "frames": N, "source": source, "compiled": fns.compiled,
            "operations_per_frame": fns.meta.get("instructions"), "imports_s": imports, "load_s": load,
            "first_eval_s": times[0], "eval_s": (statistics.median(t[0] for t in warm), statistics.median(t[1] for t in warm)),
            "run_s": again, "tile_s": tile_s, "check_max_abs_diff": same}


def _spawn(args: list[str], env: dict) -> tuple[float, float, str]:
    """Wall and CPU (user + system of the child) of one subprocess."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w = time.perf_counter()
    proc = subprocess.run(args, capture_output=True, text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - w
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{proc.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), proc.stdout


def _child_run(trial: str, compiled: str, env: dict) -> dict:
    wall, cpu, out = _spawn([sys.executable, __file__, "--child", trial, compiled], env)
    d = json.loads(out.strip().splitlines()[-1])
    d["process_s"] = (wall, cpu)
    return d


def _wait_for_background(cache: str, timeout: float = 900.0) -> float:
    """Seconds until the background compile left by a run is done (no lock file, a library or a failure)."""
    folder = Path(cache) / "ocp_constraints"
    w = time.perf_counter()
    while time.perf_counter() - w < timeout:
        locks = list(folder.glob("gait_frame_*.lock"))
        done = list(folder.glob("gait_frame_*.so.sha256")) or list(folder.glob("gait_frame_*.failed"))
        if not locks and done:
            return time.perf_counter() - w
        time.sleep(0.1)
    raise SystemExit(f"no background compile finished in {timeout:.0f} s in {folder}")


def _row(trial: str, label: str, rows: list[dict]) -> str:
    N = rows[0]["frames"]
    ew, ec = _med(rows, "eval_s", 0), _med(rows, "eval_s", 1)
    return (f"| {trial} | {label} | {N} | {_med(rows, 'load_s', 0):.3f} s / {_med(rows, 'load_s', 1):.3f} s | "
            f"{_med(rows, 'first_eval_s', 0) * 1e3:.1f} ms | {N / ew:,.0f} / {N / ec:,.0f} | "
            f"{TILE * N / _med(rows, 'tile_s', 0):,.0f} / {TILE * N / _med(rows, 'tile_s', 1):,.0f} | "
            f"{_med(rows, 'run_s', 0):.3f} s / {_med(rows, 'run_s', 1):.3f} s |")


def _med(rows: list[dict], key: str, i: int) -> float:
    return statistics.median(r[key][i] for r in rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--trials", nargs="+", default=list(TRIALS), choices=list(TRIALS))
    ap.add_argument("--markdown", type=Path, default=None, help="also write the table to this file")
    ap.add_argument("--default-only", action="store_true",
                    help="only the default's first and second run (cold cache, background compile between)")
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        print(json.dumps(child(*a.child)))
        return
    lines = ["| trial | state | frames | load (wall / CPU) | first evaluation | frames/s (wall / CPU), median of 5 | "
             f"frames/s (wall / CPU), {TILE} copies at once | run_inverse_dynamics, functions in memory |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    commands = ["| trial | command (warm caches) | wall, median | CPU, median | runs |", "|---|---|---:|---:|---:|"]
    for trial in a.trials:
        with tempfile.TemporaryDirectory(prefix="gait_bench_") as cache:
            env = {**os.environ, "XDG_CACHE_HOME": cache, "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1"}
            first = _child_run(trial, "auto", env)
            lines.append(_row(trial, f"default (auto), first run: {'C' if first['compiled'] else 'virtual machine'}",
                              [first]))
            print(lines[-1], flush=True)
            waited = _wait_for_background(cache)
            rows = [_child_run(trial, "auto", env) for _ in range(a.runs)]
            lines.append(_row(trial, f"default (auto), next runs: {'C' if rows[0]['compiled'] else 'virtual machine'} "
                                     f"(background compile done {waited:.1f} s after the first run)", rows))
            print(lines[-1], flush=True)
        if a.default_only:
            continue
        with tempfile.TemporaryDirectory(prefix="gait_bench_") as cache:
            env = {**os.environ, "XDG_CACHE_HOME": cache, "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1"}
            states = [("cold (built from .osim)", "never", 1), ("warm, virtual machine", "never", a.runs),
                      ("compile (C, once)", "always", 1), ("warm, compiled C", "auto", a.runs)]
            for label, compiled, runs in states:
                rows = [_child_run(trial, compiled, env) for _ in range(runs)]
                lines.append(_row(trial, label, rows))
                assert max(r["check_max_abs_diff"] for r in rows) < 1e-9, rows        # same numbers as the run
                print(lines[-1], flush=True)
            model, motion, grf = TRIALS[trial]
            cmd = ["ocp-constraints", "gait", "--model", str(model), "--motion", str(motion), "--grf", str(grf)]
            for label, extra, runs in (("--no-plots", ["--no-plots"], a.runs), ("--no-plots --compiled never",
                                        ["--no-plots", "--compiled", "never"], a.runs), ("with plots and report", [], 1)):
                with tempfile.TemporaryDirectory(prefix="gait_out_") as out:
                    r = [_spawn([str(Path(sys.executable).with_name("ocp-constraints")), *cmd[1:], "--out", out, *extra],
                                env)[:2] for _ in range(runs)]
                commands.append(f"| {trial} | `gait {label}` | {statistics.median(x[0] for x in r):.2f} s | "
                                f"{statistics.median(x[1] for x in r):.2f} s | {runs} |")
                print(commands[-1], flush=True)
    load = os.getloadavg()
    text = "\n".join(lines + ["", *commands, "", f"load average at the end: {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}"])
    print("\n" + text)
    if a.markdown:
        a.markdown.parent.mkdir(parents=True, exist_ok=True)
        a.markdown.write_text(text + "\n")


if __name__ == "__main__":
    main()
