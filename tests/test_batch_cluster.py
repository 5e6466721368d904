"""The embedded cluster of ``run_batch`` runs without Dask's diagnostics that cost CPU during runs.

The settings (:data:`ocp_constraints.batch.runner.QUIET_CLUSTER`) are made in the driver and
reach the worker processes only through their nannies, so they are checked where they act:
on a worker, after a task that burns 0.3 s of CPU, the statistical profiler has no samples
(with Dask's defaults it samples every 10 ms: 11 samples here), and the worker's event-loop
and memory checks run every second instead of every 20 ms and 100 ms (Dask's defaults).
"""
from __future__ import annotations

import time

import pytest

from ocp_constraints.batch.runner import _local_cluster

distributed = pytest.importorskip("distributed", reason='needs dask[distributed]: pip install -e ".[batch]"')


def _spin(seconds: float) -> None:
    t0 = time.process_time()
    while time.process_time() - t0 < seconds:
        pass


def _diagnostics(dask_worker) -> dict:
    calls = dask_worker.periodic_callbacks
    return {"samples": dask_worker.profile_recent.get("count", 0), "tick_ms": calls["tick"].callback_time,
            "memory_ms": calls["memory_monitor"].callback_time if "memory_monitor" in calls else None}


def test_the_embedded_cluster_does_not_profile_or_tick_while_runs_compute():
    cluster = _local_cluster(distributed.LocalCluster, 1)
    try:
        with distributed.Client(cluster) as client:
            client.submit(_spin, 0.3, pure=False).result()
            [seen] = client.run(_diagnostics).values()
    finally:
        cluster.close()
    assert seen == {"samples": 0, "tick_ms": 1000, "memory_ms": 1000}
