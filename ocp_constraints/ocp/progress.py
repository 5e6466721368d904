"""IPOPT's progress on the terminal, and a clean stop on Ctrl-C or SIGTERM.

CasADi calls an ``iteration_callback`` after every IPOPT iteration with the iterate; returning
1 makes IPOPT stop with status ``User_Requested_Stop`` and hand back that iterate. During a
solve, SIGINT (Ctrl-C) and SIGTERM only set a flag that the callback answers, so the solve
ends at the next iteration and the last iterate is kept (a second Ctrl-C interrupts at once).
"""
from __future__ import annotations

import signal
import sys
import threading
import time
from contextlib import contextmanager

import casadi as ca
import numpy as np

PRINT_AFTER = 2.0      # s: a solve shorter than this prints nothing
PRINT_EVERY = 1.0      # s between progress lines


class IterationMonitor(ca.Callback):
    """Counts iterations, prints progress, and asks IPOPT to stop once a stop was requested."""

    def __init__(self, nx: int, ng: int):
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.construct("iteration_monitor", {})
        self.reset(None, np.zeros(ng), np.zeros(ng))

    def reset(self, progress: bool | None, lbg: np.ndarray, ubg: np.ndarray) -> None:
        self.progress, self.lbg, self.ubg = progress, lbg, ubg
        self.iterations, self.started, self.last_print = 0, time.perf_counter(), 0.0
        self.stop_reason: str | None = None

    # -- CasADi's Callback interface: the inputs are nlpsol's outputs ------------------------------
    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "stop"

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        self.iterations += 1
        elapsed = time.perf_counter() - self.started
        show = self.progress or (self.progress is None and sys.stderr.isatty() and elapsed > PRINT_AFTER)
        if show and elapsed - self.last_print >= PRINT_EVERY:
            g = np.asarray(arg[ca.nlpsol_out().index("g")]).ravel()
            infeasibility = max(np.max(self.lbg - g, initial=0.0), np.max(g - self.ubg, initial=0.0))
            print(f"  IPOPT iteration {self.iterations}: objective {float(arg[ca.nlpsol_out().index('f')]):.8g}, "
                  f"infeasibility {infeasibility:.2e}, {elapsed:.1f} s", file=sys.stderr, flush=True)
            self.last_print = elapsed
        return [1 if self.stop_reason else 0]


@contextmanager
def stop_on_signals(monitor: IterationMonitor):
    """While solving, SIGINT and SIGTERM ask the monitor to stop IPOPT at the next iteration."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}

    def request_stop(signum, frame):
        name = signal.Signals(signum).name
        if monitor.stop_reason:          # a second signal: stop at once, as Python would
            signal.signal(signum, previous[signum])
            raise KeyboardInterrupt
        monitor.stop_reason = name
        print(f"\n  {name}: stopping IPOPT at the next iteration (the last iterate is kept)", file=sys.stderr,
              flush=True)

    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.getsignal(sig)
        signal.signal(sig, request_stop)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


class _Without:
    """A text stream that passes every line to ``stream`` but those holding ``text``."""

    def __init__(self, stream, text: str):
        self.stream, self.text, self.pending = stream, text, ""

    def __getattr__(self, name):        # isatty, fileno, encoding, ...: the stream's own
        return getattr(self.stream, name)

    def write(self, s: str) -> int:
        *lines, self.pending = (self.pending + s).split("\n")
        for line in lines:
            if self.text not in line:
                self.stream.write(line + "\n")
        return len(s)

    def flush(self) -> None:
        if self.text not in self.pending:
            self.stream.write(self.pending)
        self.pending = ""
        self.stream.flush()


@contextmanager
def without_pin_warning(pinned: bool):
    """CasADi's "NLP is overconstrained" warning left out of stderr where arcs are imposed (``pinned``): it counts each
    value held at its bound (lower bound = upper bound) as an equality, and an imposed arc holds an input at every point
    of the arc (:mod:`.imposed_arcs`), which IPOPT takes as fixed variables and solves; a solve that fails says so."""
    if not pinned:
        yield
        return
    real = sys.stderr
    sys.stderr = _Without(real, "NLP is overconstrained")
    try:
        yield
    finally:
        sys.stderr.flush()
        sys.stderr = real
