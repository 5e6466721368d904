"""A run's figures drawn by a process forked at the start, which imports matplotlib while the run computes.

Importing matplotlib's Figure and Agg canvas costs about 0.6 s of CPU, as much as a whole ``gait``
run without plots, and it needs nothing the run computes. :class:`DrawingProcess` forks a child at
the start of a command (before the heavy imports, so the fork is cheap); the child imports matplotlib,
draws a figure of the run's shape once ahead if asked (``warm``: fonts, text caches and tick artists
ready, 0.1-0.2 s off the first figure), and waits while the parent computes on the other core. At the end the parent hands it one call, e.g.
``write_gait_plots(folder, t, joints, loads)``, whose arrays are pickled through a pipe; the child
draws (sharing the figures with a forked copy of itself when a core is idle,
:mod:`.forked`) and answers with the file names. The knee's figure goes the same way
(``write_knee_figure``).

No child is forked where :func:`.forked.processes` finds no idle CPU (load average at or above the
usable CPUs, other threads, ``OCP_OUTPUT_PROCESSES=1``): measured on the shared 2-core machine at
load 4, the child's import slowed this process's computation by as much as it saved (``gait``
gait2354: 1.0 -> 1.55 s to the plots) and the whole command took longer (4.5 s wall against 3.0 s).
Then, as where ``fork`` is not available or the child fails or has died, :meth:`DrawingProcess.call`
runs the call in this process: the files are the same, only later.
"""
from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Callable

from .forked import processes

_CHILD_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _serve(conn, warm: Callable | None = None) -> None:
    """The child: import matplotlib (the slow part) and run ``warm()`` (e.g. a first draw), then one call on request."""
    # Forked with SIGINT and SIGTERM blocked (DrawingProcess.__init__): the handlers we inherit raise
    # RunInterrupted, which in a child printed raw tracebacks ("Process ocp-drawing:") and, arriving during the
    # fork's own bookkeeping, was swallowed and left the child running. Ctrl-C is the parent's to handle; the
    # parent ends us with SIGTERM, which now kills at once, also if it came before this line.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _CHILD_SIGNALS)
    try:
        from .plots import _load

        _load()
        if warm is not None:
            try:
                warm()
            except Exception:  # noqa: BLE001 - only a head start: the call draws everything itself
                pass
        request = conn.recv()
        if request is None:
            return
        fn, args, kwargs = request
        conn.send(("ok", fn(*args, **kwargs)))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which draws itself
        try:
            conn.send(("error", f"{type(exc).__name__}: {exc}"))
        except OSError:
            pass
    finally:
        conn.close()


class DrawingProcess:
    """A forked child that has matplotlib loaded by the time the figures are drawn (module docs). ``warm``: a
    module-level function the child runs while it waits, e.g. :func:`~.joint_plots.warm_gait_figure`."""

    def __init__(self, warm: Callable | None = None):
        self.error: str | None = None
        self._proc = None
        self._request, self._sent = None, False       # the call handed over by submit(), and whether it was sent
        if os.name != "posix" or "fork" not in multiprocessing.get_all_start_methods():
            self.error = "fork is not available"
            return
        if threading.active_count() > 1:        # a fork copies the other threads' memory mid-work, not the threads
            self.error = "another thread runs in this process"
            return
        if processes(2, per_process=1) < 2:     # no idle core (or OCP_OUTPUT_PROCESSES=1): it would only share ours
            self.error = "no idle CPU for a drawing process"
            return
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe()
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, _CHILD_SIGNALS)   # see _serve; ours held meanwhile
        try:
            proc = ctx.Process(target=_serve, args=(child, warm), name="ocp-drawing", daemon=True)
            proc.start()
        except (OSError, AssertionError) as exc:   # no fork here, or a daemonic parent (no children allowed)
            self.error = f"no drawing process: {exc}"
            self._conn.close()
            return
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
            child.close()
        self._proc = proc

    def call(self, fn: Callable, *args, timeout: float = 600.0, **kwargs):
        """``fn(*args, **kwargs)`` in the child (``fn`` a module-level function, the arguments picklable);
        in this process if the child cannot (reason in :attr:`error`). Its result either way."""
        self.submit(fn, *args, **kwargs)
        return self.result(timeout)

    def submit(self, fn: Callable, *args, **kwargs) -> None:
        """Hand ``fn(*args, **kwargs)`` to the child and return at once: this process writes its other files
        while the child draws; :meth:`result` waits for the answer (or runs ``fn`` here if the child cannot)."""
        self._request, self._sent = (fn, args, kwargs), False
        if self._proc is None or not self._proc.is_alive():
            self.error = self.error or "the drawing process has ended"
            return
        try:
            self._conn.send((fn, args, kwargs))
            self._sent = True
        except (OSError, EOFError) as exc:
            self.error = f"the drawing process failed: {exc}"
            self.close()

    def result(self, timeout: float = 600.0):
        """The answer to :meth:`submit`'s call: the child's, else ``fn`` run in this process (:attr:`error` says why)."""
        fn, args, kwargs = self._request
        status, value = "error", None
        if self._sent:
            try:
                if self._conn.poll(timeout):
                    status, value = self._conn.recv()
                else:
                    self.error = f"no answer after {timeout:g} s"
            except (OSError, EOFError) as exc:
                self.error = f"the drawing process failed: {exc}"
            finally:
                self._sent = False
                self.close()
        if status == "ok":
            return value
        if value is not None:
            self.error = value
        return fn(*args, **kwargs)

    def close(self) -> None:
        """End the child (idempotent). It has nothing left to finish: :meth:`call` waits for its answer,
        so an early error of the run (a bad file) ends at once instead of waiting for matplotlib."""
        if self._proc is None:
            return
        proc, self._proc = self._proc, None
        self._conn.close()
        if proc.is_alive():
            proc.terminate()
        proc.join(timeout=2.0)
