"""A warm process that forks one child per batch run: imports paid once per worker, not per run.

A run started as ``python -m ocp_constraints ARGS`` spends about 0.3 s of CPU importing NumPy,
CasADi and the library before it computes anything (``python -X importtime``), and 0.3-0.5 s
more for matplotlib when it draws. This server is started once by a Dask worker
(:mod:`.launch`), imports those modules once (:data:`PRELOAD`; :data:`PLOTTING` before the
first run that draws, i.e. has no ``--no-plots``), then reads one request per
line on stdin (JSON: ``args``, ``cwd``, ``stdout``, ``stderr``) and forks a child that runs
``python -m ocp_constraints ARGS`` in itself: its own session and process group, its folder as
working directory (also ``sys.path[0]``, as ``-m`` sets it), stdin ``/dev/null``, stdout and
stderr to the run's files, and the interpreter's normal exit (atexit handlers, flushed
streams). On stdout it answers ``{"pid": ...}`` at the fork (``{"refused": why}`` if it has
more than one thread then) and ``{"exit": ..., "cpu": ...,
"max_rss": ...}`` when the child ends (``os.wait4``: the run's own CPU time and peak memory).
A child is an independent process as a fresh one would be: Ctrl-C/SIGTERM reach it alone, its
crash costs nothing else. Forking is safe because the server has one thread (it says how many
it has in its first line; :mod:`.launch` does not use a server that has more) and BLAS/OpenMP
pools are capped at one thread, as Dask's nanny does for its workers. The server exits when
its stdin closes (the worker is gone) and, on Linux, is killed with its worker.
"""
from __future__ import annotations

import gc
import importlib
import json
import os
import runpy
import signal
import sys
import time
import traceback

# What runs of the CLI import before computing: third-party libraries first, then the modules the
# subcommands' handlers import (the CLI imports them lazily to keep --help fast).
PRELOAD = ("numpy", "casadi", "ocp_constraints", "ocp_constraints.cli.main", "ocp_constraints.scenes.registry",
           "ocp_constraints.scenes.tasks", "ocp_constraints.dynamics.simulate", "ocp_constraints.ocp.schemes")
# 0.6 s of CPU that a batch of --no-plots runs would pay for nothing (0.25 s without them)
PLOTTING = ("matplotlib", "matplotlib.pyplot")


def thread_count() -> int:
    """Threads of this process as the OS counts them (Linux ``/proc``; else Python's count)."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        import threading

        return threading.active_count()


def serve() -> None:
    """The server's main loop (``python -c "from ocp_constraints.batch.forkserver import serve; serve()"``)."""
    requests, replies = os.dup(0), os.dup(1)
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.dup2(2, 1)   # a stray print of a preloaded module must not corrupt the replies
    os.close(devnull)
    t0 = time.process_time()
    failed = _preload(PRELOAD)
    _reply(replies, {"ready": True, "pid": os.getpid(), "threads": thread_count(),
                     "preload_cpu": round(time.process_time() - t0, 3), "failed": failed})
    reader = os.fdopen(requests, "rb")
    me = os.getpid()
    code = None
    while code is None:
        line = reader.readline()
        if not line.strip():   # stdin closed: the worker is gone or done
            return
        request = json.loads(line)
        if "--no-plots" not in request["args"] and "matplotlib.pyplot" not in sys.modules:
            _preload(PLOTTING)
        if thread_count() != 1:   # (an import started a thread: forking now could deadlock the child)
            _reply(replies, {"refused": f"the fork server has {thread_count()} threads"})
            continue
        pid = os.fork()
        if pid == 0:
            code = _child(request, (requests, replies), parent=me)
            break
        _reply(replies, {"pid": pid})
        _, status, usage = os.wait4(pid, 0)
        _reply(replies, {"exit": os.waitstatus_to_exitcode(status), "cpu": round(usage.ru_utime + usage.ru_stime, 4),
                         "max_rss": usage.ru_maxrss})   # (KiB on Linux, bytes on macOS)
    sys.exit(code)   # the child leaves as `python -m` would: atexit handlers, threads joined, streams flushed


def _preload(names) -> dict[str, str]:
    """Import ``names``; returns those that failed, with why (the child then imports what it needs itself)."""
    failed = {}
    for name in names:
        try:
            importlib.import_module(name)
        except Exception as exc:   # e.g. no matplotlib
            failed[name] = f"{type(exc).__name__}: {exc}"
    # The preloaded objects out of the collector's sight: a child's collections and its exit then
    # neither walk nor copy them (its exit cost 0.22 s of CPU more without this; 0.04 s with it).
    gc.freeze()
    return failed


def _child(request: dict, server_fds: tuple[int, int], parent: int) -> int:
    """In the forked child: become the run's own process, run the CLI, return its exit status."""
    try:
        for fd in server_fds:
            os.close(fd)
        os.setsid()   # its own process group: a cancel signals the run and whatever it forked
        _die_with(parent)
        os.chdir(request["cwd"])
        for fd, path in ((1, request["stdout"]), (2, request["stderr"])):
            f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
            os.dup2(f, fd)
            os.close(f)
        sys.path[0] = os.getcwd()   # as `python -m` in the run's folder
        _reseed()
        sys.argv = ["ocp_constraints", *request["args"]]
    except BaseException:   # could not even set the run up: say why in its stderr when possible
        traceback.print_exc()
        return 1
    try:
        runpy.run_module("ocp_constraints", run_name="__main__", alter_sys=True)
    except SystemExit as exc:
        return exc.code   # (None, int or message: sys.exit handles each as the interpreter does)
    except KeyboardInterrupt:
        traceback.print_exc()
        return 128 + signal.SIGINT
    except BaseException:
        traceback.print_exc()
        return 1
    return 0


def _die_with(parent: int) -> None:
    """Linux: SIGKILL when the server dies (PR_SET_PDEATHSIG = 1), so no orphan writes a run folder."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:
        os._exit(137)


def _reseed() -> None:
    """Fresh entropy for NumPy's global generator (``random`` reseeds itself after a fork; NumPy does not)."""
    numpy = sys.modules.get("numpy")
    if numpy is not None:
        numpy.random.seed()


def _reply(fd: int, message: dict) -> None:
    data = (json.dumps(message) + "\n").encode()
    while data:
        data = data[os.write(fd, data):]
