"""Benchmark of ``ocp-constraints batch``: the same batch on 1 and on 2 Dask workers.

    python scripts/bench_batch.py [--runs 12] [--repeats 3] [--t-final 1.0]

Runs a batch of ``--runs`` pendulum simulations (a sweep of the rod length) on an
embedded ``LocalCluster`` with 1 worker and with 2 workers (single-threaded processes),
alternating, ``--repeats`` times each, and prints the wall times of whole batches
(cluster start and shutdown included), their medians and the speed-up ratio
median(1 worker) / median(2 workers). Each batch writes into a fresh temporary folder.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from ocp_constraints.batch import run_batch


def _sweeps(runs: int, t_final: float) -> list[dict]:
    lengths = [round(0.5 + 0.1 * k, 2) for k in range(runs)]
    return [{"args": ["simulate", "pendulum", "--t-final", str(t_final), "--param", "length={L}", "--no-plots"],
             "L": lengths}]


def _one(sweeps: list[dict], workers: int) -> tuple[float, float]:
    """Wall time of a whole batch and the sum of its runs' wall times."""
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as tmp:
        t0 = time.perf_counter()
        result = run_batch(sweeps, Path(tmp) / "out", workers=workers, progress=False)
        wall = time.perf_counter() - t0
    if not result.ok:
        failed = [r for r in result.rows if r["status"] != "succeeded"]
        sys.exit(f"bench_batch: {len(failed)} run(s) failed, e.g. {failed[0]['id']}: {failed[0]['message']}")
    return wall, sum(r["wall_time"] for r in result.rows)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=12, help="runs per batch (default 12, at least 12)")
    p.add_argument("--repeats", type=int, default=3, help="batches per worker count (default 3)")
    p.add_argument("--t-final", type=float, default=1.0, help="simulated time per run [s] (default 1.0)")
    args = p.parse_args(argv)
    if args.runs < 12 or args.repeats < 1:
        p.error("--runs must be at least 12 and --repeats at least 1")
    sweeps = _sweeps(args.runs, args.t_final)
    print(f"bench_batch: {args.runs} runs of `simulate pendulum --t-final {args.t_final:g}` per batch, "
          f"{args.repeats} batches per worker count; {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.2f} at start")
    times: dict[int, list[float]] = {1: [], 2: []}
    for rep in range(args.repeats):
        for workers in (1, 2):
            wall, busy = _one(sweeps, workers)
            times[workers].append(wall)
            print(f"  repeat {rep + 1}, {workers} worker(s): batch {wall:6.2f} s (runs' own wall times sum "
                  f"to {busy:6.2f} s)", flush=True)
    m1, m2 = statistics.median(times[1]), statistics.median(times[2])
    print(f"median batch wall time: 1 worker {m1:.2f} s, 2 workers {m2:.2f} s")
    print(f"speed-up 1 -> 2 workers: {m1 / m2:.2f}x (load average {os.getloadavg()[0]:.2f} at the end)")
    return 0


if __name__ == "__main__":   # (needed: the cluster's worker processes are spawned)
    sys.exit(main())
