"""How a batch task starts its run: a child of a warm fork server, else a fresh ``python -m``.

:func:`run_command` runs ``python -m ocp_constraints ARGS`` in ``cwd`` with stdout and stderr
to files, waits for it while watching the batch's cancel file (SIGTERM to the run's process
group when it appears, SIGKILL 5 s later) and returns an :class:`Outcome`: exit status, the
run's own CPU time and peak memory (``wait4``), and how it was started. By default
(``warm=True``, POSIX) the run is a child of a :mod:`.forkserver` of this worker process,
which has NumPy, CasADi, matplotlib and the library imported already: about 0.3 s of CPU less
per run than a fresh interpreter (``python scripts/bench_batch.py --fixed-cost``). A server
is started on a worker's first run and reused (one per concurrently executing task thread);
if one cannot start or has more than one thread (forking would be unsafe), this process
runs fresh interpreters instead. A run's environment is the worker's, with ``MPLBACKEND=Agg``
and one BLAS/OpenMP thread unless set (a run is one core's work: the batch's parallelism is
across runs, as Dask's nanny sets for its workers).
"""
from __future__ import annotations

import atexit
import json
import os
import select
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass

DEFAULT_ENV = {"MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
GRACE = 5.0      # [s] between SIGTERM and SIGKILL of a cancelled run
POLL = 0.25      # [s] how often a waiting task looks at the cancel file
START_TIMEOUT = 300.0   # [s] for a server's imports on a loaded machine
SERVER = "from ocp_constraints.batch.forkserver import serve; serve()"


@dataclass
class Outcome:
    """How a run ended: ``code`` (negative: killed by that signal), ``cancelled``, CPU [s], peak RSS [MB]."""

    code: int | None
    cancelled: bool
    cpu_time: float | None
    max_rss_mb: float | None
    launch: str   # "warm" (a fork server's child) or "fresh" (a new interpreter)


class ServerLost(RuntimeError):
    """A fork server stopped answering."""


class NotStarted(ServerLost):
    """A fork server was gone before it forked the run: nothing was started."""


class Refused(NotStarted):
    """A fork server would not fork (it has more than one thread): nothing was started."""


def run_environment() -> dict[str, str]:
    env = dict(os.environ)
    for key, value in DEFAULT_ENV.items():
        env.setdefault(key, value)
    return env


def run_command(args: list[str], cwd: str, stdout: str, stderr: str, cancel_file: str, warm: bool = True
                ) -> Outcome:
    """Run ``python -m ocp_constraints ARGS`` (see the module's docstring); raises :class:`ServerLost`
    when a warm server died under a running run (the Dask task is then retried)."""
    server = _acquire() if warm else None
    if server is None:
        return _fresh(args, cwd, stdout, stderr, cancel_file)
    try:
        outcome = server.run(args, cwd, stdout, stderr, cancel_file)
    except NotStarted as exc:   # nothing ran: this run in a fresh interpreter instead
        server.close()
        if isinstance(exc, Refused):
            _COLD.append(str(exc))
        return _fresh(args, cwd, stdout, stderr, cancel_file)
    except BaseException:
        server.close()
        raise
    _release(server)
    return outcome


# -- warm: fork servers of this process ---------------------------------------------------------
_IDLE: list["ForkServer"] = []
_LOCK = threading.Lock()
_COLD: list[str] = []   # why this process gave up on fork servers (then every run is fresh)


def warm_status() -> str:
    """'warm', or why this process starts fresh interpreters."""
    return f"fresh ({_COLD[0]})" if _COLD else "warm"


def _acquire() -> "ForkServer | None":
    if os.name != "posix" or not hasattr(os, "fork") or _COLD:
        return None
    with _LOCK:
        while _IDLE:
            server = _IDLE.pop()
            if server.proc.poll() is None:
                return server
            server.close()   # (died while idle, e.g. killed with the thread that had started it)
    try:
        return ForkServer()
    except (OSError, ServerLost, ValueError) as exc:
        _COLD.append(f"no fork server: {exc}")
        return None


def _release(server: "ForkServer") -> None:
    with _LOCK:
        _IDLE.append(server)


@atexit.register
def shutdown() -> None:
    """Close this process's idle fork servers (they also exit by themselves when it dies)."""
    with _LOCK:
        idle = list(_IDLE)
        _IDLE.clear()
    for server in idle:
        server.close()


class ForkServer:
    """One :mod:`.forkserver` process and its pipes; one run at a time."""

    def __init__(self):
        self.proc = subprocess.Popen([sys.executable, "-c", SERVER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     env=run_environment(), start_new_session=True, preexec_fn=die_with_parent())
        self._buf = b""
        hello = self._message(START_TIMEOUT)
        if hello.get("threads") != 1:
            self.close()
            raise ValueError(f"the server has {hello.get('threads')} threads, forking it would be unsafe")
        self.preload_cpu = hello.get("preload_cpu")

    def run(self, args, cwd, stdout, stderr, cancel_file) -> Outcome:
        try:
            self._send({"args": list(args), "cwd": str(cwd), "stdout": str(stdout), "stderr": str(stderr)})
            started = self._message(START_TIMEOUT)   # (after the server's imports for a first run that draws)
        except ServerLost as exc:
            raise NotStarted(str(exc)) from exc
        if "refused" in started:
            raise Refused(started["refused"])
        pid = started["pid"]
        cancelled, killed_at = False, None
        while True:
            msg = self._message(POLL, allow_timeout=True)
            if msg is not None:
                return Outcome(msg["exit"], cancelled, msg["cpu"], _mb(msg["max_rss"]), "warm")
            if not cancelled and os.path.exists(cancel_file):
                cancelled, killed_at = True, time.monotonic()
                _signal_group(pid, signal.SIGTERM)
            elif killed_at is not None and time.monotonic() - killed_at > GRACE:
                _signal_group(pid, signal.SIGKILL)
                killed_at = None

    def close(self) -> None:
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=5)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()
        self.proc.stdout.close()

    def _send(self, message: dict) -> None:
        try:
            self.proc.stdin.write((json.dumps(message) + "\n").encode())
            self.proc.stdin.flush()
        except OSError as exc:
            raise ServerLost(f"fork server {self.proc.pid}: {exc}") from exc

    def _message(self, timeout: float, allow_timeout: bool = False) -> dict | None:
        """The server's next line as a dict (None after ``timeout`` if ``allow_timeout``)."""
        end = time.monotonic() + timeout
        fd = self.proc.stdout.fileno()
        while b"\n" not in self._buf:
            left = end - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                if allow_timeout:
                    return None
                raise ServerLost(f"fork server {self.proc.pid} did not answer within {timeout:g} s")
            chunk = os.read(fd, 65536)
            if not chunk:
                raise ServerLost(f"fork server {self.proc.pid} exited (status {self.proc.poll()})")
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return json.loads(line)


# -- fresh: a new interpreter per run --------------------------------------------------------------
def _fresh(args, cwd, stdout, stderr, cancel_file) -> Outcome:
    with open(stdout, "wb") as fout, open(stderr, "wb") as ferr:
        proc = subprocess.Popen([sys.executable, "-m", "ocp_constraints", *args], cwd=cwd, env=run_environment(),
                                stdin=subprocess.DEVNULL, stdout=fout, stderr=ferr, start_new_session=True,
                                preexec_fn=die_with_parent())
    cancelled, killed_at, delay = False, None, 0.005
    while True:
        if hasattr(os, "wait4"):
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                proc.returncode = os.waitstatus_to_exitcode(status)   # reaped here: Popen must not wait again
                return Outcome(proc.returncode, cancelled, round(usage.ru_utime + usage.ru_stime, 4),
                               _mb(usage.ru_maxrss), "fresh")
        elif proc.poll() is not None:   # (Windows: no wait4, so no CPU time or peak memory)
            return Outcome(proc.returncode, cancelled, None, None, "fresh")
        time.sleep(delay)
        delay = min(2 * delay, POLL)
        if not cancelled and os.path.exists(cancel_file):
            cancelled, killed_at = True, time.monotonic()
            _signal_group(proc.pid, signal.SIGTERM)
        elif killed_at is not None and time.monotonic() - killed_at > GRACE:
            _signal_group(proc.pid, getattr(signal, "SIGKILL", signal.SIGTERM))
            killed_at = None


def _mb(max_rss: int) -> float:
    """``ru_maxrss`` in MB (Linux counts it in KiB, macOS in bytes)."""
    return round(max_rss / (2**20 if sys.platform == "darwin" else 2**10), 1)


def _signal_group(pid: int, sig: int) -> None:
    try:
        if hasattr(os, "killpg"):
            os.killpg(pid, sig)   # the run leads its own session: the run and whatever it forked
        else:
            os.kill(pid, signal.SIGTERM)   # (Windows: terminates the process)
    except (ProcessLookupError, PermissionError):
        pass


def die_with_parent():
    """Linux: a ``preexec_fn`` that has the child killed when this process dies (no orphan writing a folder)."""
    if not sys.platform.startswith("linux"):
        return None
    import ctypes

    try:
        prctl = ctypes.CDLL("libc.so.6", use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    parent = os.getpid()

    def child():   # between fork and exec: PR_SET_PDEATHSIG = 1
        prctl(1, signal.SIGKILL)
        if os.getppid() != parent:
            os._exit(137)
    return child
