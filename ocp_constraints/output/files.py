"""Writing results: ``summary.json``, ``trajectory.csv``, ``loads.csv`` (plots: :mod:`.plots`, OpenSim
storage files: :mod:`.sto`, the HTML report: :mod:`.report`).

The format is DESIGN.md's results contract (external checkers read these files).
Every file is written whole: to a temporary file in the same folder, then renamed, so
a crash never leaves a half-written file that looks complete; it gets the permissions the
user's umask gives (``0666 & ~umask``, as ``open()`` would), not ``mkstemp``'s private 0600.
A run's folder is written whole by :class:`RunFolder` (see there).
"""
from __future__ import annotations

import io
import json
import os
import platform
import tempfile
from pathlib import Path

import numpy as np

from ..errors import OcpConstraintsError


def software_versions() -> dict[str, str]:
    """Versions of the software the run used: SciPy only if the run imported it (a simulation does
    not; importing it just for its version cost 15-40 ms of start-up)."""
    import sys

    import casadi

    from .._version import __version__

    versions = {"ocp_constraints": __version__, "python": platform.python_version(), "casadi": casadi.__version__,
                "numpy": np.__version__}
    if "scipy" in sys.modules:
        versions["scipy"] = sys.modules["scipy"].__version__
    return versions


def prepare_output_folder(out: str | Path) -> Path:
    """Create ``out`` (and parents); a clear error if it cannot be written."""
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise _not_a_folder(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=path, prefix=".write-test-", delete=True)
        probe.close()
    except OSError as exc:
        raise OcpConstraintsError(f"cannot write results to '{path}': {exc.strerror or exc}; give an --out folder "
                                  "you can write to") from exc
    return path


def check_output_folder(out: str | Path) -> None:
    """The error :func:`prepare_output_folder` would raise, raised before a run computes anything, and nothing
    created: ``out``, or the nearest folder above it that exists, must be a folder this process can write."""
    path = Path(out)
    existing = path
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    if existing == path and path.exists() and not path.is_dir():
        raise _not_a_folder(path)
    if not existing.is_dir():
        raise OcpConstraintsError(f"cannot write results to '{path}': '{existing}' is not a folder; give an --out "
                                  "folder you can write to")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OcpConstraintsError(f"cannot write results to '{path}': '{existing}' is not writable; give an --out "
                                  "folder you can write to")


def _not_a_folder(path: Path) -> OcpConstraintsError:
    return OcpConstraintsError(f"cannot write results to '{path}': it exists and is not a folder; give another "
                               "--out (a folder, new or earlier results)")


def current_umask() -> int:
    """The process's umask (read from /proc where it can be, so nothing is changed even briefly)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename (mode ``0666 & ~umask``)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~current_umask())   # mkstemp's 0600 would survive the rename
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def replace_between_markers(path: Path, start: str, end: str, text: str | None, what: str) -> None:
    """Replace what lies between the lines ``start`` and ``end`` of ``path`` by ``text`` (the file
    written whole); ``text=None`` only checks that the markers are there, once each and in order.
    ``what`` names the command in the error (a :class:`SceneError` naming the file and the markers)."""
    from ..errors import SceneError

    try:
        current = Path(path).read_text()
    except OSError as exc:
        raise SceneError(f"{what}: cannot read {path}: {exc.strerror}") from exc
    if current.count(start) != 1 or current.count(end) != 1 or current.index(start) > current.index(end):
        raise SceneError(f"{what}: {path} needs one line '{start}' and, after it, one line '{end}'; the text "
                         f"goes between them")
    if text is None:
        return
    head, rest = current.split(start)
    tail = rest.split(end, 1)[1]
    write_atomic(Path(path), f"{head}{start}\n{text.rstrip()}\n{end}{tail}".encode())


def write_json(path: Path, data: dict) -> None:
    write_atomic(path, (json.dumps(data, indent=2, sort_keys=False, default=_json_default) + "\n").encode())


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def write_csv(path: Path, t: np.ndarray, columns: dict[str, np.ndarray]) -> None:
    """A ``t`` column then one column per entry, full double precision."""
    names = ["t", *columns]
    data = np.column_stack([np.asarray(t, float)] + [np.asarray(v, float) for v in columns.values()])
    buf = io.StringIO()
    np.savetxt(buf, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    write_atomic(path, buf.getvalue().encode())
