"""Running a batch on Dask: each run is ``python -m ocp_constraints ARGS`` in a task.

:func:`run_batch` submits one task per run (``retries=2``; a run on a worker that dies is
rescheduled by the scheduler) and records the results as they arrive in ``DIR/batch.csv``
and ``DIR/batch.json``. A task runs the command in a process of its own (:mod:`.launch`: by
default a child forked from a warm server of its worker, imports done once) with its ``--out``
at ``DIR/runs/<id>/`` (appended when the command takes ``--out`` and the template has no
``{out}``), captures ``stdout.txt``/``stderr.txt`` there and, after an exit status 0,
writes ``done.json`` last (atomically): with ``resume=True`` such runs are skipped.
``DIR`` must be visible at the same path to the workers (one machine or a shared disk).
On Ctrl-C the queued runs are cancelled, running ones terminated, the table written with
them as ``cancelled``, and ``KeyboardInterrupt`` raised again. The embedded cluster runs
without Dask's diagnostics that cost CPU while runs compute (:data:`QUIET_CLUSTER`).
"""
from __future__ import annotations

import importlib.util
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import uuid
from dataclasses import dataclass, replace
from pathlib import Path

from .launch import run_command
from .spec import OUT, Run, as_runs
from .table import ProgressLine, atomic_write_json, counts, make_row, read_json, read_summary, write_table

DONE = "done.json"
_TAKES_OUT: dict[str, bool] = {}
# Dask settings of the embedded cluster. With two runs computing on two cores, the defaults cost
# 14-16 % of a core in the scheduler, nannies and workers while nothing happens (tasks that sleep,
# python scripts/bench_batch.py --idle): the worker's statistical profiler samples every 10 ms,
# every server checks its event loop every 20 ms, the nanny measures its worker's memory every
# 100 ms, the system monitor every 500 ms. A batch task is one long call without Dask data,
# so none of these tell anything; with these settings the same cost is about 2 %.
QUIET_CLUSTER = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                 "distributed.worker.memory.monitor-interval": "1s",
                 "distributed.admin.system-monitor.interval": "10s"}


@dataclass
class BatchResult:
    """The rows of a finished batch and the folder holding ``batch.csv``/``batch.json``."""

    out: Path
    rows: list[dict]

    @property
    def counts(self) -> dict[str, int]:
        return counts(self.rows)

    @property
    def ok(self) -> bool:
        return all(r["status"] in ("succeeded", "skipped") for r in self.rows)


def run_batch(specs, out, client=None, workers: int = 2, resume: bool = False, progress: bool | None = True,
              warm: bool = True) -> BatchResult:
    """Run every run of ``specs`` (a spec file path, a list of sweep dicts or of :class:`Run`).

    ``client``: a ``distributed.Client`` to use; by default an embedded ``LocalCluster`` of
    ``workers`` single-threaded processes is started and closed. ``progress``: the Dask
    dashboard's address and one status line on stderr (``None``: the line only when stderr is
    a terminal). ``warm``: runs forked from a warm server per worker (:mod:`.launch`); False:
    a fresh interpreter per run. Returns the rows; raises ``KeyboardInterrupt`` again after a Ctrl-C.
    """
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError as exc:
        raise ImportError('ocp-constraints batch needs Dask: pip install -e ".[batch]"') from exc
    runs = [_with_out(r) for r in as_runs(specs)]

    out = Path(out).resolve()
    (out / "runs").mkdir(parents=True, exist_ok=True)
    rows = [make_row(r) for r in runs]
    meta = {"out": str(out), "started": time.strftime("%Y-%m-%dT%H:%M:%S"), "resume": resume}
    todo = []
    for i, run in enumerate(runs):
        rec = read_json(out / "runs" / run.id / DONE) if resume else None
        if rec and rec.get("exit_code") == 0 and rec.get("args") == list(run.args):
            rows[i] = _row(run, rec, "skipped")
        else:
            todo.append(i)
    write_table(out, rows, meta)
    if not todo:
        return BatchResult(out, rows)
    show = sys.stderr.isatty() if progress is None else bool(progress)
    token = uuid.uuid4().hex[:12]
    cancel_file = out / f".cancel-{token}"
    bar = ProgressLine(show, len(todo), len(runs) - len(todo))
    futures: dict = {}
    cluster = None
    interrupted = False
    try:
        if client is None:
            cluster = _local_cluster(LocalCluster, workers)
            client = Client(cluster)
        meta["scheduler"] = client.scheduler.address
        try:
            link = client.dashboard_link
        except Exception:   # this scheduler serves no dashboard
            link = None
        if link and progress is not False:
            # Without bokeh, Dask serves only its /info pages there and a page asking for bokeh
            plots = "" if importlib.util.find_spec("bokeh") else ' (its plots need bokeh: pip install "bokeh>=3.1.0")'
            print(f"Dask dashboard: {link}{plots}", file=sys.stderr)
        for i in todo:
            run, run_dir = runs[i], out / "runs" / runs[i].id
            fut = client.submit(execute_run, run.command_args(run_dir), str(run_dir), run.cwd, token,
                                str(cancel_file), list(run.args), warm, key=f"{run.id}-{token}", retries=2,
                                pure=False)
            futures[fut] = i
        ac = as_completed(list(futures), with_results=True, raise_errors=False, loop=client.loop)
        while not ac.is_empty():
            batch = ac.next_batch(block=False)
            for fut, res in batch:
                rows[futures[fut]] = _row(runs[futures[fut]], _result(fut, res))
                fut.release()   # recorded: a worker lost later need not recompute it
            if batch:
                write_table(out, rows, meta)
            else:
                time.sleep(0.1)
            if bar.due(force=bool(batch)):
                bar.show(rows, _running(client, futures, rows))
    except KeyboardInterrupt:
        interrupted = True
        cancel_file.touch()
        if futures:
            _interrupt(client, futures, runs, rows, out, token)
        for i, row in enumerate(rows):
            if row["status"] == "pending":
                rows[i] = make_row(runs[i], "cancelled", message="cancelled (the batch was interrupted)")
        meta["interrupted"] = True
        write_table(out, rows, meta)
        raise
    finally:
        bar.close()
        for fut in futures:
            fut.release()
        if cluster is not None:
            if client is not None:
                client.close()
            cluster.close()
        if not interrupted:   # (kept after Ctrl-C: a late task still sees it and stops)
            cancel_file.unlink(missing_ok=True)
    return BatchResult(out, rows)


def execute_run(args: list[str], run_dir: str, cwd: str, token: str, cancel_file: str, template: list[str],
                warm: bool = True) -> dict:
    """The Dask task of one run: the CLI command in a process of its own, outputs in ``run_dir``.

    Returns a record (status, exit code, wall and CPU time [s], peak memory [MB], worker,
    message, headline numbers), written as ``done.json`` after a success. Re-executed in the
    same batch (its worker died after finishing), it returns the recorded result instead of
    running again.
    """
    run_dir_p = Path(run_dir)
    rec = read_json(run_dir_p / DONE)
    if rec and rec.get("token") == token:
        return rec
    rec = {"status": "cancelled", "exit_code": None, "wall_time": None, "cpu_time": None, "max_rss_mb": None,
           "worker": _worker_address(), "message": "", "numbers": {}, "token": token, "args": template}
    if os.path.exists(cancel_file):
        return rec
    if run_dir_p.exists():
        shutil.rmtree(run_dir_p)
    run_dir_p.mkdir(parents=True)
    t0 = time.perf_counter()
    done = run_command(args, cwd, str(run_dir_p / "stdout.txt"), str(run_dir_p / "stderr.txt"), cancel_file, warm)
    rec.update(wall_time=round(time.perf_counter() - t0, 3), cpu_time=done.cpu_time, max_rss_mb=done.max_rss_mb,
               launch=done.launch)
    if done.cancelled:
        rec["message"] = "cancelled (the batch was interrupted)"
        return rec
    code = done.code
    rec.update(status="succeeded" if code == 0 else "failed", exit_code=code, numbers=read_summary(run_dir_p))
    if code != 0:
        rec["message"] = _last_line(run_dir_p / "stderr.txt") or f"exit status {code}"
    else:
        atomic_write_json(run_dir_p / DONE, rec)   # last: the run is complete
    return rec


def _local_cluster(LocalCluster, workers: int):
    """An embedded cluster whose worker processes ignore Ctrl-C (the driver stops them cleanly)."""
    import threading

    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    import dask

    try:   # spawned workers inherit SIG_IGN; the nannies hand the configuration to their workers
        with dask.config.set(QUIET_CLUSTER):
            return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                                host="127.0.0.1", silence_logs=logging.CRITICAL)
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)


def _interrupt(client, futures: dict, runs: list[Run], rows: list[dict], out: Path, token: str) -> None:
    """Ctrl-C: cancel queued runs, let running ones see the cancel file and stop, record what finished."""
    from distributed import wait

    pending = [f for f, i in futures.items() if rows[i]["status"] == "pending"]
    try:
        running = {k for keys in client.processing().values() for k in keys}
        client.cancel([f for f in pending if f.key not in running])
        wait([f for f in pending if f.key in running], timeout=15)
        client.cancel(pending)
    except (KeyboardInterrupt, Exception):   # a second Ctrl-C, a timeout, a lost scheduler: stop waiting
        pass
    for fut in pending:   # done.json of this batch: finished whole, whether or not its result arrived
        i = futures[fut]
        rec = read_json(out / "runs" / runs[i].id / DONE)
        if rec and rec.get("token") == token:
            rows[i] = _row(runs[i], rec)


def _result(fut, res) -> dict:
    """The record of a completed future (judged by its result: the future may be 'lost' since)."""
    if isinstance(res, dict):
        return res
    if fut.status == "error" or (isinstance(res, tuple) and len(res) == 3 and isinstance(res[1], BaseException)):
        exc = res[1] if isinstance(res, tuple) and len(res) == 3 else res
        return {"status": "failed", "message": f"{type(exc).__name__}: {exc}".strip()}
    return {"status": "cancelled", "message": "cancelled"}


def _row(run: Run, rec: dict, status: str | None = None) -> dict:
    return make_row(run, status or rec.get("status", "failed"), rec.get("exit_code"), rec.get("wall_time"),
                    rec.get("worker", ""), rec.get("message", ""), rec.get("numbers"), cpu_time=rec.get("cpu_time"),
                    max_rss_mb=rec.get("max_rss_mb"))


def _with_out(run: Run) -> Run:
    """Append ``--out {out}`` when the command takes ``--out`` and the template does not set it."""
    token = "{" + OUT + "}"
    if any(token in a or a == "--out" or a.startswith("--out=") for a in run.args):
        return run
    command = run.args[0]
    if command not in _TAKES_OUT:   # ask the command itself (once per command and process)
        try:
            p = subprocess.run([sys.executable, "-m", "ocp_constraints", command, "--help"], cwd=run.cwd,
                               capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
            _TAKES_OUT[command] = p.returncode == 0 and re.search(r"--out\b", p.stdout) is not None
        except (OSError, subprocess.SubprocessError):
            _TAKES_OUT[command] = False
    return replace(run, args=(*run.args, "--out", token)) if _TAKES_OUT[command] else run


def _last_line(path: Path) -> str:
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").strip().splitlines()
    except OSError:
        return ""
    return lines[-1].strip() if lines else ""


def _worker_address() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return ""


def _running(client, futures: dict, rows: list[dict]) -> int:
    """How many of the batch's unfinished runs workers are executing now (at most one per thread)."""
    try:
        processing, nthreads = client.processing(), client.nthreads()
    except Exception:   # scheduler busy or gone: the line just shows 0
        return 0
    ours = {f.key for f, i in futures.items() if rows[i]["status"] == "pending"}
    return sum(min(len(ours.intersection(keys)), nthreads.get(w, 1)) for w, keys in processing.items())
