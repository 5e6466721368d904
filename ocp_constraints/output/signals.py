"""SIGINT and SIGTERM during a run: one path for both, and no signal in the middle of writing results.

The command line runs every command inside :func:`interrupt_on_signals`: SIGINT (Ctrl-C) and
SIGTERM (``kill``, a batch system's time limit) both raise
:class:`~ocp_constraints.errors.RunInterrupted`, a ``KeyboardInterrupt`` that names the signal, in
the main thread. The code that was running keeps what it computed (``exc.partial``; ``simulate``
stops at the last complete sample) and the results writer writes it with ``"success": false`` and
``"status": "interrupted by SIGINT"``. While a results folder is committed
(:func:`signals_deferred`) a first signal is held until every file is in place; a second one
aborts the commit (the folder keeps the previous run's files).

A ``KeyboardInterrupt`` raised from a signal handler lands in whatever Python code runs at that
moment, and C extensions that call back into Python turn it into their own error (NumPy: a
``SystemError`` from ``DM.__array__``; CasADi: a ``RuntimeError`` of the call). So code that can
stop at safe points runs inside :func:`polling`: there the handler only records the signal, and
the code raises it with :func:`raise_if_signalled` between its steps (``simulate`` does, once per
segment). The command line also treats any error that follows a signal as the interruption.

CasADi's ``nlpsol`` (3.8) catches a ``KeyboardInterrupt`` raised while IPOPT runs and returns with
status ``NonIpopt_Exception_Thrown`` instead of raising it (checked with the installed CasADi);
:func:`signal_mark` and :func:`signal_since` tell whether a signal arrived meanwhile, and
:func:`watching_sigint` records SIGINT for library callers that did not install these handlers.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator

from ..errors import RunInterrupted

_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_received: list[str] = []          # every signal our handler saw, in order
_defer = {"depth": 0, "held": None}
_poll = {"depth": 0}


def _handler(signum, frame) -> None:  # noqa: ARG001 - the signal module's signature
    name = signal.Signals(signum).name
    _received.append(name)
    if _defer["depth"] and _defer["held"] is None:
        _defer["held"] = name          # raised when the results are in place
        return
    if _poll["depth"]:
        return                         # raised by raise_if_signalled at the next safe point
    raise RunInterrupted(name)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def interrupt_on_signals(signals=_SIGNALS) -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`RunInterrupted` inside the block (main thread only; elsewhere a no-op).

    The previous handlers are restored on the way out.
    """
    if not _in_main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in signals}
    for s in signals:
        signal.signal(s, _handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)


@contextmanager
def watching_sigint() -> Iterator[None]:
    """Record SIGINT during the block (e.g. around ``nlpsol``, which swallows the ``KeyboardInterrupt``).

    A no-op when :func:`interrupt_on_signals` is already active or outside the main thread, so the
    command line's SIGTERM handling is kept.
    """
    if not _in_main_thread() or signal.getsignal(signal.SIGINT) is _handler:
        yield
        return
    with interrupt_on_signals((signal.SIGINT,)):
        yield


def signal_mark() -> int:
    """A mark to pass to :func:`signal_since`."""
    return len(_received)


def signal_since(mark: int) -> str | None:
    """Name of the first signal received after ``mark`` (``"SIGINT"``, ``"SIGTERM"``), or None."""
    return _received[mark] if len(_received) > mark else None


@contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold a first SIGINT/SIGTERM until the block ends (then raise it); a second one is raised at once."""
    _defer["depth"] += 1
    try:
        yield
    finally:
        _defer["depth"] -= 1
        held = _defer["held"] if _defer["depth"] == 0 else None
        if _defer["depth"] == 0:
            _defer["held"] = None
    if held is not None:
        raise RunInterrupted(held)


def call_interruptibly(function, *args, **kwargs):
    """``function(*args, **kwargs)`` (e.g. a ``casadi.nlpsol`` solver); a SIGINT or SIGTERM that arrived
    during the call, which ``nlpsol`` swallows (it returns ``NonIpopt_Exception_Thrown``), is raised
    after it as :class:`RunInterrupted`."""
    mark = signal_mark()
    with watching_sigint():
        out = function(*args, **kwargs)
    name = signal_since(mark)
    if name is not None:
        raise RunInterrupted(name)
    return out


@contextmanager
def polling() -> Iterator[None]:
    """Inside the block, SIGINT/SIGTERM are only recorded; call :func:`raise_if_signalled` at safe points."""
    _poll["depth"] += 1
    try:
        yield
    finally:
        _poll["depth"] -= 1


def raise_if_signalled(mark: int) -> None:
    """Raise :class:`RunInterrupted` if a signal arrived after ``mark`` (see :func:`signal_mark`)."""
    name = signal_since(mark)
    if name is not None:
        raise RunInterrupted(name)


def as_interruption(exc: BaseException, mark: int) -> BaseException | None:
    """``exc`` itself if it is a ``KeyboardInterrupt``; a :class:`RunInterrupted` if a signal arrived after
    ``mark`` (the error is then what the signal became inside NumPy or CasADi); else None."""
    if isinstance(exc, KeyboardInterrupt):
        return exc
    name = signal_since(mark)
    return RunInterrupted(name) if name is not None else None
