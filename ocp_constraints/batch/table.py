"""The batch table: one row per run, written as ``batch.csv`` and ``batch.json``, atomically.

A row holds the run's id, its arguments (``{out}`` standing for ``runs/<id>/``), the
sweep variables' values, status (pending, succeeded, failed, skipped, cancelled), exit
code, wall time [s], the run process's own CPU time [s] and peak resident memory [MB],
worker, the message of a failure, and the headline numbers of the
run's ``summary.json`` flattened with dots (``objective``, ``iterations``, ``success``,
``max_constraint_residual.position``, any key containing ``rmse`` ...). A headline key
that collides with a row field is prefixed ``summary.`` (e.g. ``summary.status``).
Both files are written to a temporary file and renamed over the old one, so a reader
(or an interrupted batch) always sees a whole table. :class:`ProgressLine` shows the
table's counts on one terminal line while the batch runs.
"""
from __future__ import annotations

import csv
import io
import json
import os
import shlex
import sys
import tempfile
import time
from pathlib import Path

STATUSES = ("pending", "succeeded", "failed", "skipped", "cancelled")
FIELDS = ["id", "status", "exit_code", "wall_time", "cpu_time", "max_rss_mb", "worker", "message", "args"]
# summary.json entries worth a column (dotted paths); any scalar whose key contains "rmse" is added too
HEADLINE = ["success", "status", "objective", "iterations", "t_reached", "max_constraint_residual.position",
            "max_constraint_residual.velocity", "energy.relative_error", "reintegration.max_state_deviation"]


def flatten(data, prefix: str = "") -> dict:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}`` (lists are left out)."""
    flat = {}
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten(value, name + "."))
        elif not isinstance(value, list):
            flat[name] = value
    return flat


def headline(summary: dict) -> dict:
    """The headline numbers of a ``summary.json``, flattened, in a fixed order."""
    if not isinstance(summary, dict):
        return {}
    flat = flatten(summary)
    keys = [k for k in HEADLINE if k in flat]
    keys += [k for k in flat if "rmse" in k.rsplit(".", 1)[-1].lower() and k not in keys]
    out = {}
    for k in keys:
        if isinstance(flat[k], (int, float, str, bool)) or flat[k] is None:
            out["summary." + k if k in FIELDS else k] = flat[k]
    return out


def read_json(path: str | os.PathLike) -> dict | None:
    """The JSON object in ``path`` (None when absent, unreadable or not an object)."""
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def read_summary(run_dir: str | os.PathLike) -> dict:
    """The headline numbers of ``run_dir/summary.json`` ({} when absent or unreadable)."""
    return headline(read_json(Path(run_dir) / "summary.json") or {})


def make_row(run, status: str = "pending", exit_code=None, wall_time=None, worker: str = "",
             message: str = "", numbers: dict | None = None, cpu_time=None, max_rss_mb=None) -> dict:
    """A table row of ``run`` (a :class:`~ocp_constraints.batch.spec.Run`); times in s, memory in MB."""
    row = {"id": run.id, "status": status, "exit_code": exit_code, "wall_time": wall_time, "cpu_time": cpu_time,
           "max_rss_mb": max_rss_mb, "worker": worker, "message": message, "args": list(run.args)}
    row.update({f"var.{k}": v for k, v in run.values.items()})
    row.update(numbers or {})
    return row


def columns(rows: list[dict]) -> list[str]:
    """Fixed fields, then sweep variables, then headline numbers, each in order of first appearance."""
    seen: list[str] = []
    for row in rows:
        seen += [k for k in row if k not in FIELDS and k not in seen]
    return FIELDS + [k for k in seen if k.startswith("var.")] + [k for k in seen if not k.startswith("var.")]


def write_table(out: str | os.PathLike, rows: list[dict], meta: dict | None = None) -> None:
    """Write ``out/batch.csv`` and ``out/batch.json`` (each whole, via a temporary file)."""
    out = Path(out)
    cols = columns(rows)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(cols)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in cols])
    _atomic_write(out / "batch.csv", buf.getvalue())
    doc = dict(meta or {})
    doc["counts"] = counts(rows)
    doc["runs"] = rows
    _atomic_write(out / "batch.json", json.dumps(doc, indent=2, default=str) + "\n")


def read_table(out: str | os.PathLike) -> list[dict]:
    """The rows of ``out/batch.csv`` as dicts of strings (for checks and tests)."""
    with open(Path(out) / "batch.csv", newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def counts(rows: list[dict]) -> dict[str, int]:
    return {s: sum(r["status"] == s for r in rows) for s in STATUSES}


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, list):
        return shlex.join(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


def atomic_write_json(path: str | os.PathLike, data) -> None:
    """Write ``data`` as JSON to ``path`` via a temporary file and ``os.replace``."""
    _atomic_write(Path(path), json.dumps(data, indent=2, default=str) + "\n")


def _atomic_write(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)   # mkstemp makes it 0600
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


class ProgressLine:
    """One line on stderr, rewritten with ``\\r``: done, failed, running, queued, elapsed, ETA."""

    def __init__(self, enabled: bool, total: int, skipped: int = 0, every: float = 1.0):
        self.enabled, self.total, self.skipped, self.every = enabled, total, skipped, every
        self.t0, self.last, self.width = time.monotonic(), -every, 0

    def due(self, force: bool = False) -> bool:
        """Time to redraw (at most every ``every`` seconds unless ``force``)?"""
        return self.enabled and (force or time.monotonic() - self.last >= self.every)

    def show(self, rows: list[dict], running: int) -> None:
        now = self.last = time.monotonic()
        c = counts(rows)
        finished = c["succeeded"] + c["failed"] + c["cancelled"]
        left = self.total - finished
        eta = clock((now - self.t0) / finished * left) if finished else "--:--"
        line = (f"batch: {finished}/{self.total} done, {c['failed']} failed, {running} running, "
                f"{max(left - running, 0)} queued" + (f", {self.skipped} skipped" if self.skipped else "")
                + f", elapsed {clock(now - self.t0)}, ETA {eta}")
        self.width = max(self.width, len(line))
        sys.stderr.write("\r" + line.ljust(self.width))
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled and self.width:
            sys.stderr.write("\n")
            sys.stderr.flush()


def clock(seconds: float) -> str:
    """``m:ss`` (``h:mm:ss`` from an hour on)."""
    m, s = divmod(int(round(seconds)), 60)
    return f"{m // 60}:{m % 60:02d}:{s:02d}" if m >= 60 else f"{m}:{s:02d}"
