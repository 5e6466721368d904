"""Independent pieces of output work (the figures of a run) shared with forked copies of this process.

Drawing a run's five to eight figures is single-threaded Python (matplotlib) at about 0.2 s of CPU each,
and the machines this runs on have a second core idle by then. :func:`run_split` forks ``k - 1``
children after the caller has imported what the work needs (so they inherit it, copy-on-write, at no
import cost), and each process takes every ``k``-th item. The children write their files and end with
``os._exit``; the parent waits for them. A child that fails or is killed costs nothing but time: the
parent does that child's items itself, so the files are the same as from one process.

No fork where it is unsafe or useless: without ``os.fork``, with other threads running in this
process (a fork copies only the calling thread, and locks another thread held stay held), with one
usable CPU, with fewer than two items per process, or when the machine has no idle CPU (the 1-minute
load average, this process included, at or above the number of usable CPUs: measured on the shared 2-core machine at load 3-8,
a second process won no wall time and cost 0.3-0.5 s of CPU; a batch keeps every core busy too).
``OCP_OUTPUT_PROCESSES=1`` turns it off, ``=N`` asks for N processes whatever the load.
"""
from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Sequence

ENV = "OCP_OUTPUT_PROCESSES"


def processes(n_items: int, per_process: int = 2) -> int:
    """How many processes to share ``n_items`` among: at most one per usable CPU (two by default), each
    with at least ``per_process`` items; 1 where forking is unsafe or unavailable (module docs)."""
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = os.cpu_count() or 1
    wanted = os.environ.get(ENV, "").strip()
    try:
        k = int(wanted) if wanted else min(2, usable)
    except ValueError:
        k = 1                        # a malformed setting means: do not fork (never an error here)
    if not wanted and _load() >= usable:
        k = 1                        # no idle core: a second process would only share ours
    if not hasattr(os, "fork") or threading.active_count() > 1:
        return 1
    return max(1, min(k, usable, n_items // max(1, per_process)))


def run_split(items: Sequence, work: Callable[[Sequence], None], k: int | None = None) -> None:
    """``work(part)`` over ``items`` in ``k`` processes (default :func:`processes`): this one takes
    ``items[0::k]``, forked child ``i`` takes ``items[i::k]``. Returns when all items are done; an
    error of this process's ``work`` propagates (the children are ended first)."""
    k = processes(len(items)) if k is None else k
    if k <= 1:
        work(items)
        return
    children: list[tuple[int, Sequence]] = []
    for i in range(1, k):
        part = items[i::k]
        pid = os.fork()
        if pid == 0:                                    # the child: its part, then leave at once
            code = 1
            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)    # Ctrl-C is the parent's; it ends us
                work(part)
                code = 0
            except BaseException:                      # noqa: BLE001 - the parent does the part again
                pass
            finally:
                os._exit(code)                          # no atexit handlers, no flush of inherited buffers
        children.append((pid, part))
    try:
        work(items[0::k])
    except BaseException:
        for pid, _ in children:
            _end(pid)
        raise
    failed = [x for pid, part in children if not _succeeded(pid) for x in part]
    if failed:
        work(failed)


def _load() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:
        return 0.0


def _succeeded(pid: int) -> bool:
    _, status = os.waitpid(pid, 0)
    return os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0


def _end(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGTERM)
        os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass
