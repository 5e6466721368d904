"""Benchmark of ``ocp-constraints batch``: 1 against 2 Dask workers, and where the CPU goes.

    python scripts/bench_batch.py [--runs 12] [--repeats 3] [--t-final 1.0] [--launch warm|fresh|both]
    python scripts/bench_batch.py --idle 10        # Dask's own CPU while tasks wait: its defaults against ours
    python scripts/bench_batch.py --fixed-cost 5   # CPU to start a run: forked from a warm server against fresh
    python scripts/bench_batch.py --costs 3        # CPU time and peak memory per run of each kind (README)

The default mode runs batches of ``--runs`` pendulum simulations (a sweep of the rod length) on an
embedded ``LocalCluster`` configured as ``run_batch`` configures it, with 1 and 2 workers,
alternating, ``--repeats`` times each. Per batch it prints the wall time of the whole batch
(cluster start, the runs, shutdown) and of each phase, and the CPU time of every process: the
runs (each run's own, from ``wait4``), the driver (scheduler, nannies, client, the table), the
worker processes and their fork servers. The overhead is everything but the runs. At the end,
medians and the speed-up median(1 worker) / median(2 workers) of the whole batch and of its run
phase, and each run's median CPU time with 1 and with 2 workers (if it grows with 2 workers,
the two runs slow each other down in the hardware: caches, memory, the hypervisor; "steal" is
the CPU time the hypervisor gave to other machines, /proc/stat). Wall times
are only meaningful on an otherwise idle machine; CPU times much less so.
"""
from __future__ import annotations

import argparse
import logging
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import psutil

from ocp_constraints.batch import launch, run_batch
from ocp_constraints.batch.runner import _local_cluster

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
JW = DATA / "grand-challenge-knee-jw"
G2354 = DATA / "opensim-gait2354-subject01"
JW_ARGS = ["--model", str(JW / "reducepoly_model/JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"),
           "--motion", str(JW / "reducepoly_subject_GC/IK/IK_ngait_og5.mat"),
           "--grf", str(JW / "reducepoly_subject_GC/GRF/GRF_ngait_og5.mat")]
KINDS = {   # the README's "Cost per run" rows
    "simulate pendulum (10 s)": ["simulate", "pendulum", "--t-final", "10"],
    "simulate ball_socket (10 s)": ["simulate", "ball_socket", "--t-final", "10"],
    "solve pendulum (Radau 3, N = 50)": ["solve", "pendulum", "--scheme", "radau", "--degree", "3",
                                         "--intervals", "50"],
    "solve ball_socket (reach, Radau 3, N = 50)": ["solve", "ball_socket", "--task", "reach", "--scheme", "radau",
                                                   "--degree", "3", "--intervals", "50"],
    "gait gait2354 subject01": ["gait", "--model", str(G2354 / "subject01_simbody.osim"),
                                "--motion", str(G2354 / "subject01_walk1_ik.mot"),
                                "--grf", str(G2354 / "subject01_walk1_grf.mot")],
    "gait JW ngait_og5": ["gait", *JW_ARGS],
    "knee JW ngait_og5 (static)": ["knee", *JW_ARGS,
                                   "--measured", str(JW / "reducepoly_subject_GC/KCF/KCF_ngait_og5.mat")],
}


def _cpu(p: psutil.Process) -> float:
    try:
        t = p.cpu_times()
    except psutil.NoSuchProcess:
        return 0.0
    return t.user + t.system


def _cluster(workers: int, quiet: bool = True):
    from distributed import Client, LocalCluster

    if quiet:
        cluster = _local_cluster(LocalCluster, workers)   # exactly as run_batch starts its own
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                               host="127.0.0.1", silence_logs=logging.CRITICAL)
    client = Client(cluster)
    pids = client.run(os.getpid)
    return cluster, client, [psutil.Process(pid) for pid in pids.values()]


def _batch(sweeps: list[dict], workers: int, warm: bool) -> dict:
    """One whole batch on its own embedded cluster: wall per phase, CPU per process."""
    w0, c0, s0 = time.perf_counter(), time.process_time(), _steal()
    cluster, client, procs = _cluster(workers)
    w1, c1 = time.perf_counter(), time.process_time()
    k1 = sum(_cpu(p) for p in procs)
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as tmp:
        result = run_batch(sweeps, Path(tmp) / "out", client=client, progress=False, warm=warm)
    w2, c2, s2 = time.perf_counter(), time.process_time(), _steal()
    k2 = sum(_cpu(p) for p in procs)
    servers = sum(_cpu(s) for p in procs for s in p.children())   # fork servers (started within the batch)
    client.close()
    cluster.close()
    w3 = time.perf_counter()
    if not result.ok:
        failed = [r for r in result.rows if r["status"] != "succeeded"]
        sys.exit(f"bench_batch: {len(failed)} run(s) failed, e.g. {failed[0]['id']}: {failed[0]['message']}")
    runs = [r["cpu_time"] for r in result.rows]
    return {"whole": w3 - w0, "start": w1 - w0, "phase": w2 - w1, "close": w3 - w2, "driver_start": c1 - c0,
            "driver": c2 - c1, "workers": k2 - k1, "servers": servers, "runs_cpu": sum(runs), "run_cpu": runs,
            "runs_wall": sum(r["wall_time"] for r in result.rows), "steal": s2 - s0}


def _steal() -> float:
    """CPU time the hypervisor gave to other guests while this one wanted it [s, all CPUs]."""
    return getattr(psutil.cpu_times(), "steal", 0.0)


def speedup(args) -> None:
    lengths = [round(0.5 + 0.1 * k, 2) for k in range(args.runs)]
    sweeps = [{"args": ["simulate", "pendulum", "--t-final", str(args.t_final), "--param", "length={L}",
                        "--no-plots", "--out", "{out}"], "L": lengths}]
    modes = {"warm": [True], "fresh": [False], "both": [True, False]}[args.launch]
    print(f"bench_batch: {args.runs} runs of `simulate pendulum --t-final {args.t_final:g} --no-plots` per batch, "
          f"{args.repeats} batches per worker count and launch; {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.2f} at start")
    got: dict = {}
    for rep in range(args.repeats):
        for warm in modes:
            for workers in (1, 2):
                b = _batch(sweeps, workers, warm)
                got.setdefault((warm, workers), []).append(b)
                over = b["driver"] + b["workers"] + b["servers"]
                print(f"  repeat {rep + 1}, {'warm ' if warm else 'fresh'}, {workers} worker(s): whole "
                      f"{b['whole']:6.2f} s (start {b['start']:.2f}, runs {b['phase']:.2f}, close {b['close']:.2f}); "
                      f"runs' wall sum {b['runs_wall']:.2f} s. CPU: runs {b['runs_cpu']:.2f} s "
                      f"({b['runs_cpu'] / args.runs:.3f} per run), "
                      f"driver {b['driver']:.2f} (+{b['driver_start']:.2f} at start), workers {b['workers']:.2f}, "
                      f"fork servers {b['servers']:.2f}: overhead {over:.2f} s = {100 * over / b['runs_cpu']:.1f} % "
                      f"of the runs' CPU; steal {b['steal']:.2f} s", flush=True)
    print(f"medians (load average {os.getloadavg()[0]:.2f} at the end):")
    for warm in modes:
        m = {w: {k: statistics.median(b[k] for b in got[(warm, w)]) for k in ("whole", "phase")} for w in (1, 2)}
        per_run = {w: statistics.median(x for b in got[(warm, w)] for x in b["run_cpu"]) for w in (1, 2)}
        print(f"  {'warm ' if warm else 'fresh'}: whole batch 1 worker {m[1]['whole']:.2f} s, 2 workers "
              f"{m[2]['whole']:.2f} s: speed-up {m[1]['whole'] / m[2]['whole']:.2f}x; run phase {m[1]['phase']:.2f} / "
              f"{m[2]['phase']:.2f} s: {m[1]['phase'] / m[2]['phase']:.2f}x; CPU per run {per_run[1]:.3f} s (1 worker) "
              f"and {per_run[2]:.3f} s (2 workers)")


def idle(args) -> None:
    """CPU of the driver and the workers while every worker's task sleeps ``args.idle`` s."""
    print(f"bench_batch --idle: {args.idle:g} s sleeping tasks on 2 workers, CPU in % of one core "
          f"(load average {os.getloadavg()[0]:.2f})")
    for rep in range(args.repeats):
        for quiet in (False, True):
            cluster, client, procs = _cluster(2, quiet)   # quiet: QUIET_CLUSTER, as run_batch's own cluster
            client.submit(time.sleep, 0.1, pure=False).result()
            me = psutil.Process()
            d0, k0, t0 = _cpu(me), [_cpu(p) for p in procs], time.perf_counter()
            client.gather([client.submit(time.sleep, args.idle, pure=False) for _ in procs])
            d1, k1, el = _cpu(me), [_cpu(p) for p in procs], time.perf_counter() - t0
            client.close()
            cluster.close()
            print(f"  {'run_batch settings' if quiet else 'Dask defaults     '}: driver {100 * (d1 - d0) / el:.1f} %, "
                  "workers " + ", ".join(f"{100 * (b - a) / el:.1f} %" for a, b in zip(k0, k1)), flush=True)


def fixed_cost(args) -> None:
    """CPU of a run that does almost nothing, forked from a warm server and as a fresh interpreter."""
    tiny = ["simulate", "pendulum", "--t-final", "0.01", "--dt", "0.01", "--no-plots"]
    cpu = {True: [], False: []}
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as tmp:
        t0 = time.process_time()
        server = launch.ForkServer()
        print(f"bench_batch --fixed-cost: a fork server's imports took {server.preload_cpu:.2f} s CPU "
              f"(once per worker; the launcher's own {time.process_time() - t0:.2f} s)")
        for k in range(args.fixed_cost):
            for warm in (True, False):
                out = os.path.join(tmp, f"run{k}{warm}")
                files = (os.path.join(tmp, "stdout.txt"), os.path.join(tmp, "stderr.txt"), os.path.join(tmp, "no"))
                if warm:
                    o = server.run([*tiny, "--out", out], tmp, *files)
                else:
                    o = launch.run_command([*tiny, "--out", out], tmp, *files, warm=False)
                assert o.code == 0, open(files[1]).read()
                cpu[warm].append(o.cpu_time)
        server.close()
    w, f = statistics.median(cpu[True]), statistics.median(cpu[False])
    print(f"  `{' '.join(tiny)}`, median of {args.fixed_cost}: fresh interpreter {f:.3f} s CPU, forked from the "
          f"warm server {w:.3f} s: {f - w:.3f} s less per run (load average {os.getloadavg()[0]:.2f})")


def costs(args) -> None:
    """Every kind of run once per batch on one worker, ``args.costs`` batches per launch: CPU and peak memory."""
    print(f"bench_batch --costs: the {len(KINDS)} kinds in one batch on 1 worker, {args.costs} batches warm and "
          f"{args.costs} fresh, alternating; medians (load average {os.getloadavg()[0]:.2f} at start)", flush=True)
    sweeps = [{"args": [*argv, "--no-plots", "--out", "{out}"]} for argv in KINDS.values()]
    got: dict = {(name, warm): [] for name in KINDS for warm in (True, False)}
    for rep in range(args.costs):
        for warm in (True, False):
            with tempfile.TemporaryDirectory(prefix="bench_batch_") as tmp:
                r = run_batch(sweeps, Path(tmp) / "out", workers=1, progress=False, warm=warm)
            for name, argv, row in zip(KINDS, KINDS.values(), r.rows):
                assert row["args"][:len(argv)] == argv
                if row["status"] != "succeeded":
                    sys.exit(f"bench_batch: {name} failed: {row['message']}")
                got[(name, warm)].append(row)

    def med(name, warm, key):
        return statistics.median(row[key] for row in got[(name, warm)])

    print("\n| run | CPU time, forked (fresh) | wall at this load | peak memory, fresh (forked) |")
    print("|---|---:|---:|---:|")
    for name in KINDS:
        print(f"| `{name}` | {med(name, True, 'cpu_time'):.2f} s ({med(name, False, 'cpu_time'):.2f} s) | "
              f"{med(name, True, 'wall_time'):.1f} s | {med(name, False, 'max_rss_mb'):.0f} MB "
              f"({med(name, True, 'max_rss_mb'):.0f} MB) |")
    print(f"\n(load average {os.getloadavg()[0]:.2f} at the end; a forked run's peak memory also counts the pages "
          "it shares with its fork server)")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=12, help="runs per batch (default 12, at least 12)")
    p.add_argument("--repeats", type=int, default=3, help="batches per worker count (default 3)")
    p.add_argument("--t-final", type=float, default=1.0, help="simulated time per run [s] (default 1.0)")
    p.add_argument("--launch", choices=["warm", "fresh", "both"], default="warm",
                   help="runs forked from a warm server (run_batch's default), fresh interpreters, or both")
    p.add_argument("--idle", type=float, metavar="SECONDS", help="measure Dask's own CPU while tasks sleep")
    p.add_argument("--fixed-cost", type=int, metavar="N", help="measure the CPU to start a run, N times each way")
    p.add_argument("--costs", type=int, metavar="N", help="CPU and memory per run of each kind, N runs each")
    args = p.parse_args(argv)
    if args.runs < 12 or args.repeats < 1:
        p.error("--runs must be at least 12 and --repeats at least 1")
    if args.idle:
        idle(args)
    elif args.fixed_cost:
        fixed_cost(args)
    elif args.costs:
        costs(args)
    else:
        speedup(args)
    return 0


if __name__ == "__main__":   # (needed: the cluster's worker processes are spawned)
    sys.exit(main())
