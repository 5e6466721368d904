"""The knee figure drawn in a second process, which imports matplotlib while the first one computes.

Importing matplotlib costs about 0.8 s of CPU, as much as a fifth of a whole ``knee`` run, and
it needs nothing the run computes. :class:`FigureProcess` forks a child at the start of the
command. The child imports matplotlib and waits. While it does, the parent runs the inverse
dynamics and the static optimisation on the other core. At the end the parent sends the
curves, and the child draws ``knee_contact.png`` into the run's staging folder.

Where ``fork`` is not available (Windows, macOS's default), or if the child fails or has died,
:meth:`FigureProcess.draw` returns None. The caller then draws in its own process, and the
result is the same file.
"""
from __future__ import annotations

import multiprocessing
import os
import signal
from pathlib import Path

NAME = "knee_contact.png"


def _serve(conn) -> None:
    """The child: import matplotlib (the slow part), then draw one figure on request."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)      # Ctrl-C is the parent's to handle; it ends us
    os.environ.setdefault("MPLBACKEND", "Agg")
    try:
        from ..output.joint_plots import knee_figure
        from ..output.plots import pyplot, save

        pyplot()
        request = conn.recv()
        if request is None:
            return
        folder, args = request
        written: list[str] = []
        save(knee_figure(*args), Path(folder), NAME, written, dpi=100)
        conn.send(("ok", written[0]))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which draws itself
        try:
            conn.send(("error", f"{type(exc).__name__}: {exc}"))
        except OSError:
            pass
    finally:
        conn.close()


class FigureProcess:
    """A forked child that has matplotlib loaded by the time the figure is needed (module docstring)."""

    def __init__(self):
        self.error: str | None = None
        self._proc = None
        if os.name != "posix" or "fork" not in multiprocessing.get_all_start_methods():
            self.error = "fork is not available"
            return
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe()
        try:
            proc = ctx.Process(target=_serve, args=(child,), name="knee-figure", daemon=True)
            proc.start()
        except (OSError, AssertionError) as exc:   # no fork here, or a daemonic parent (no children allowed)
            self.error = f"no figure process: {exc}"
            self._conn.close()
            return
        finally:
            child.close()
        self._proc = proc

    def draw(self, folder: Path, args: tuple, timeout: float = 120.0) -> str | None:
        """Draw ``knee_figure(*args)`` as ``folder/knee_contact.png`` in the child; its name, or None
        (reason in :attr:`error`) if the child cannot."""
        if self._proc is None or not self._proc.is_alive():
            self.error = self.error or "the figure process has ended"
            return None
        try:
            self._conn.send((str(folder), args))
            if not self._conn.poll(timeout):
                self.error = f"no figure after {timeout:g} s"
                return None
            status, value = self._conn.recv()
        except (OSError, EOFError) as exc:
            self.error = f"the figure process failed: {exc}"
            return None
        finally:
            self.close()
        if status != "ok":
            self.error = value
            return None
        return value

    def close(self) -> None:
        """End the child (idempotent). It has nothing left to finish: :meth:`draw` waits for its answer,
        so an early error of the run (a bad file) ends at once instead of waiting for matplotlib."""
        if self._proc is None:
            return
        proc, self._proc = self._proc, None
        self._conn.close()
        if proc.is_alive():
            proc.terminate()
        proc.join(timeout=2.0)
