"""A run's results folder, written whole: a new run replaces the previous run's files, and nothing else.

How (and why not a folder swap). Every file of a run is first written into a private staging
folder inside ``out`` (same file system, so a rename moves a file atomically). :meth:`RunFolder.commit`
then, holding a lock on the folder and with SIGINT/SIGTERM deferred:

1. writes the manifest ``.ocp-constraints-run.json`` listing the previous run's files *and* the new
   ones (so a crash from here on leaves nothing the next run does not know to clean up);
2. removes the previous ``summary.json`` first (the folder stops claiming to hold a complete run),
   then every file the previous run wrote that this run does not (stale plots, old tables);
3. renames the new files into place, ``summary.json`` last;
4. writes the manifest of this run and removes the staging folder.

A reader that goes by ``summary.json`` therefore sees the previous run complete, no summary (a
commit in progress, a few milliseconds), or the new run complete, never a mixture. Only files a
run of this toolkit wrote are ever removed: the manifest names them (for a folder written before
manifests existed, the files its ``summary.json`` lists). A sibling-folder swap was not chosen
because ``--out`` may be a folder that also holds the user's own files (or ``.``), which a swap
would throw away; POSIX ``rename`` cannot replace a non-empty folder (a swap takes two renames,
with a moment where the folder does not exist, or Linux's ``renameat2``), and a swap changes the
folder's identity under a shell, a file browser or a web server that has it open.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from ..errors import OcpConstraintsError
from .files import prepare_output_folder, write_atomic
from .signals import signals_deferred

MANIFEST = ".ocp-constraints-run.json"
STAGING_PREFIX = ".ocp-constraints-staging-"
SUMMARY = "summary.json"
_ACTIVE: set[Path] = set()   # staging folders of this process that are being written


class RunFolder:
    """The results folder ``out`` of one run.

    ``RunFolder(out)`` creates ``out`` and checks that it can be written (so a bad ``--out``
    fails before any computing); :meth:`begin` gives the staging folder to write every file
    into; :meth:`commit` puts them in place (see the module docstring); :meth:`abort` drops them.
    """

    def __init__(self, out: str | Path):
        self.path = prepare_output_folder(out)
        self.staging: Path | None = None
        self.committed: list[str] = []     # the file names of the last commit

    def begin(self) -> Path:
        """A fresh staging folder (leftovers of an earlier crashed run are removed first)."""
        for old in self.path.glob(f"{STAGING_PREFIX}*"):
            if old.is_dir() and not old.is_symlink() and old not in _ACTIVE and not _writer_alive(old.name):
                shutil.rmtree(old, ignore_errors=True)
        self.abort()
        try:
            self.staging = Path(tempfile.mkdtemp(dir=self.path, prefix=f"{STAGING_PREFIX}{os.getpid()}-"))
        except OSError as exc:
            raise self._write_error(exc) from exc
        _ACTIVE.add(self.staging)
        return self.staging

    def _write_error(self, exc: OSError) -> OcpConstraintsError:
        return OcpConstraintsError(f"cannot write results to '{self.path}': {exc.strerror or exc}")

    def abort(self) -> None:
        """Drop the staged files; the folder keeps what it held."""
        if self.staging is not None:
            _ACTIVE.discard(self.staging)
            shutil.rmtree(self.staging, ignore_errors=True)
            self.staging = None

    @contextmanager
    def staged(self):
        """``with folder.staged() as staging:`` write every file into ``staging``; on leaving the block they
        are committed (:meth:`commit`). An exception drops them and the folder keeps what it held; an
        ``OSError`` while writing (a full disk, a quota) becomes the one-line :class:`OcpConstraintsError`
        that names the folder, not a traceback. The committed file names are then in :attr:`committed`."""
        staging = self.begin()
        try:
            yield staging
        except OSError as exc:
            self.abort()
            raise self._write_error(exc) from exc
        except BaseException:
            self.abort()
            raise
        self.committed = self.commit()

    def previous_files(self) -> set[str]:
        """Files an earlier run of the toolkit wrote here (by the manifest, else by its summary.json)."""
        try:
            listed = json.loads((self.path / MANIFEST).read_text()).get("files", [])
            return {n for n in listed if _plain_name(n)}
        except (OSError, ValueError, AttributeError):
            pass
        return _files_named_by_summary(self.path / SUMMARY)

    def commit(self) -> list[str]:
        """Replace the previous run's files with the staged ones; returns the new file names."""
        if self.staging is None:
            raise RuntimeError("RunFolder.commit() without begin()")
        new: list[str] = []
        done = False
        try:
            with signals_deferred(), _FolderLock(self.path):
                new = sorted(p.name for p in self.staging.iterdir())
                old = self.previous_files()
                _write_manifest(self.path, sorted(old | set(new)))
                stale = sorted(old - set(new))
                for name in ([SUMMARY] if SUMMARY in old else []) + [n for n in stale if n != SUMMARY]:
                    _remove_file(self.path / name)
                for name in sorted(new, key=lambda n: n == SUMMARY):   # summary.json last
                    os.replace(self.staging / name, self.path / name)
                _write_manifest(self.path, new)
                done = True
        except OSError as exc:
            raise self._write_error(exc) from exc
        except KeyboardInterrupt as exc:   # held during the commit, raised once the files were in place
            if done:
                exc.written_to = str(self.path)
            raise
        finally:
            self.abort()
        return new


def _writer_alive(staging_name: str) -> bool:
    """Whether the process that made a staging folder (its pid is in the name) still runs."""
    try:
        pid = int(staging_name[len(STAGING_PREFIX):].split("-")[0])
    except ValueError:
        return False
    if pid == os.getpid():
        return False   # this process, and not in _ACTIVE: a write that failed before commit()
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:   # exists, owned by someone else
        return True
    return True


def _plain_name(name) -> bool:
    return isinstance(name, str) and name not in ("", ".", "..", MANIFEST) and "/" not in name and "\\" not in name


def _files_named_by_summary(summary: Path) -> set[str]:
    """A folder from before manifests: its ``summary.json`` (if the toolkit wrote it) names the files."""
    try:
        data = json.loads(summary.read_text())
    except (OSError, ValueError):
        return set()
    if not isinstance(data, dict) or "ocp_constraints" not in (data.get("software") or {}):
        return set()
    names = {SUMMARY, "trajectory.csv", "loads.csv"}
    names.update(n for n in data.get("plots") or [] if isinstance(n, str))
    if isinstance(data.get("report"), str):
        names.add(data["report"])
    if str(data.get("task", "")).startswith("gait"):
        names.update(f"gait_{j}.png" for j in data.get("leg_joints") or {})
    if str(data.get("task", "")).startswith("knee"):
        names.add("knee_contact.png")
    return {n for n in names if _plain_name(n) and (summary.parent / n).is_file()}


def _remove_file(path: Path) -> None:
    if path.is_file() or path.is_symlink():
        path.unlink()


def _write_manifest(folder: Path, files: list[str]) -> None:
    text = json.dumps({"written_by": "ocp_constraints", "files": files}, indent=1) + "\n"
    write_atomic(folder / MANIFEST, text.encode())


class _FolderLock:
    """An exclusive ``flock`` on the folder itself, so two runs into one folder commit one after the other."""

    def __init__(self, path: Path):
        self.path, self.fd = path, None

    def __enter__(self):
        try:
            import fcntl

            self.fd = os.open(self.path, os.O_RDONLY)
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        except (ImportError, OSError):   # no flock here: commit without it
            if self.fd is not None:
                os.close(self.fd)
            self.fd = None
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            os.close(self.fd)   # closing releases the lock


def write_interrupted_run(out: str | Path, task: str, exc: BaseException, inputs: dict | None = None) -> str:
    """A run interrupted before any result was complete: ``summary.json`` alone, ``"success": false``
    and the reason (the previous run's files go, so the folder does not show them as this run's).
    Returns the folder; also sets ``exc.written_to``."""
    from .files import software_versions, write_json
    from ..errors import interruption_reason

    if getattr(exc, "written_to", None):   # the results were complete and written when the signal came
        return exc.written_to
    folder = RunFolder(out)
    staging = folder.begin()
    try:
        reason = interruption_reason(exc)
        write_json(staging / SUMMARY, {"task": task, "success": False, "status": reason,
                                       "message": f"{reason} before any result was complete; nothing else was written",
                                       "inputs": inputs or {}, "software": software_versions()})
        folder.commit()
    except BaseException:
        folder.abort()
        raise
    exc.written_to = str(folder.path)
    return str(folder.path)
