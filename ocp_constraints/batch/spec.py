"""Batch specs: a TOML file of ``[[sweep]]`` tables, expanded into runs with stable ids.

A sweep is a CLI argument template plus sweep variables; the runs are the Cartesian
product of the variables' values (in the order the variables are written)::

    [[sweep]]
    args = ["solve", "pendulum", "--degree", "{d}", "--intervals", "{N}"]
    d = [3, 5]
    N = [20, 40, 80]

A variable is a list of values or ``{ glob = "pattern" }`` (the sorted matches, relative
to the spec file's folder, given as absolute paths). ``{out}`` stands for the run's
folder (``DIR/runs/<id>/``) and is filled in by the runner. Runs execute in the spec
file's folder, so relative paths in a spec are relative to it. A run's id is made of the
command, its first argument (unless a variable gives it), the variables' values and a hash of the whole
argument list: the same arguments give the same id on every expansion.

Bad input raises :class:`BatchSpecError` naming the spec file, the sweep and the key.
"""
from __future__ import annotations

import glob as _glob
import hashlib
import itertools
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import BatchSpecError

OUT = "out"   # the placeholder of the run's folder
_PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")
_UNSAFE = re.compile(r"[^A-Za-z0-9._=+-]+")


@dataclass(frozen=True)
class Run:
    """One run of a batch: CLI arguments (``{out}`` not yet filled in) and where they came from."""

    id: str
    args: tuple[str, ...]
    cwd: str
    sweep: int = 1
    values: dict = field(default_factory=dict, compare=False, hash=False)

    def command_args(self, run_dir: str | os.PathLike) -> list[str]:
        """The argument list with ``{out}`` replaced by the run's folder."""
        return [a.replace("{" + OUT + "}", str(run_dir)) for a in self.args]


def load_spec(path: str | os.PathLike) -> list[Run]:
    """The runs of the spec file ``path`` (TOML, ``[[sweep]]`` tables)."""
    path = Path(path)
    if not path.is_file():
        raise BatchSpecError(f"batch spec '{path}' does not exist")
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise BatchSpecError(f"batch spec '{path}': not valid TOML: {exc}") from exc
    except OSError as exc:
        raise BatchSpecError(f"batch spec '{path}' cannot be read: {exc}") from exc
    unknown = sorted(set(data) - {"sweep"})
    if unknown:
        raise BatchSpecError(f"batch spec '{path}': unknown top-level key(s) {', '.join(map(repr, unknown))}; "
                             "a spec holds [[sweep]] tables only")
    if "sweep" not in data:
        raise BatchSpecError(f"batch spec '{path}' has no [[sweep]] table")
    return expand_sweeps(data["sweep"], path.resolve().parent, source=str(path))


def as_runs(specs) -> list[Run]:
    """Runs of a spec file path, a ``{"sweep": [...]}`` dict, a list of sweep dicts or a list of :class:`Run`."""
    if isinstance(specs, (str, os.PathLike)):
        return load_spec(specs)
    if isinstance(specs, dict) and "sweep" in specs:
        return expand_sweeps(specs["sweep"])
    if isinstance(specs, (list, tuple)) and specs and all(isinstance(s, Run) for s in specs):
        ids = [s.id for s in specs]
        repeated = sorted({i for i in ids if ids.count(i) > 1})
        if repeated:
            raise BatchSpecError(f"runs: duplicate run id(s) {', '.join(repeated)}")
        return list(specs)
    if isinstance(specs, (list, tuple)) and all(isinstance(s, dict) for s in specs):
        return expand_sweeps(list(specs))
    raise BatchSpecError("specs must be a spec file path, a list of sweep tables (dicts) or a list of Run, "
                         f"not {type(specs).__name__}")


def expand_sweeps(sweeps, base_dir: str | os.PathLike | None = None, source: str = "batch spec") -> list[Run]:
    """Runs of a list of sweep tables (dicts with ``args`` and sweep variables).

    ``base_dir`` (default: the current folder) is where globs are resolved and runs execute.
    """
    base = Path(base_dir if base_dir is not None else os.getcwd()).resolve()
    if not isinstance(sweeps, list) or not sweeps:
        raise BatchSpecError(f"{source}: 'sweep' must be a non-empty list of tables ([[sweep]])")
    runs: list[Run] = []
    seen: dict[str, Run] = {}
    for i, sweep in enumerate(sweeps, start=1):
        where = f"{source}: sweep {i}"
        for run in _expand_one(sweep, i, where, base):
            if run.id in seen:
                first = seen[run.id]
                raise BatchSpecError(
                    f"{where}: duplicate run id '{run.id}' (values {run.values}) repeats the run of sweep "
                    f"{first.sweep} (values {first.values}): the same arguments twice")
            seen[run.id] = run
            runs.append(run)
    return runs


def _expand_one(sweep, index: int, where: str, base: Path) -> list[Run]:
    if not isinstance(sweep, dict):
        raise BatchSpecError(f"{where}: must be a table with 'args' and sweep variables, not {type(sweep).__name__}")
    args = sweep.get("args")
    if not isinstance(args, list) or not args:
        raise BatchSpecError(f"{where}: 'args' must be a non-empty list of CLI arguments, e.g. "
                             "args = [\"simulate\", \"pendulum\", \"--param\", \"length={L}\"]")
    for k, a in enumerate(args):
        if isinstance(a, bool) or not isinstance(a, (str, int, float)):
            raise BatchSpecError(f"{where} (args[{k}]): {a!r} is not a string or number")
    args = [_text(a) for a in args]
    variables: dict[str, list[str]] = {}
    for key, value in sweep.items():
        if key == "args":
            continue
        if key == OUT:
            raise BatchSpecError(f"{where} ({key}): '{OUT}' is reserved for the run's folder; rename the variable")
        if not _PLACEHOLDER.fullmatch("{" + key + "}"):
            raise BatchSpecError(f"{where} ({key}): a variable name is letters, digits and '_' (not starting "
                                 "with a digit)")
        variables[key] = _values(value, f"{where} ({key})", base)
    used = {m for a in args for m in _PLACEHOLDER.findall(a)}
    unknown = sorted(used - set(variables) - {OUT})
    if unknown:
        known = ", ".join("{" + v + "}" for v in [*variables, OUT])
        raise BatchSpecError(f"{where} (args): unknown placeholder(s) {', '.join('{' + u + '}' for u in unknown)}; "
                             f"known here: {known}")
    unused = [v for v in variables if v not in used]
    if unused:
        raise BatchSpecError(f"{where} ({unused[0]}): variable is not used in args (write {{{unused[0]}}} "
                             "where its value goes)")
    runs = []
    for combo in itertools.product(*variables.values()):
        values = dict(zip(variables, combo))
        filled = tuple(_PLACEHOLDER.sub(lambda m: values.get(m.group(1), m.group(0)), a) for a in args)
        runs.append(Run(run_id(filled, values), filled, str(base), index, values))
    return runs


def _values(value, where: str, base: Path) -> list[str]:
    if isinstance(value, dict):
        if set(value) != {"glob"} or not isinstance(value["glob"], str) or not value["glob"]:
            raise BatchSpecError(f"{where}: a table value must be {{ glob = \"pattern\" }}, got {value!r}")
        pattern = value["glob"]
        full = os.path.join(str(base), pattern)   # (keeps a trailing "/": folders only)
        matches = sorted({m.rstrip("/\\") or m for m in _glob.glob(full)})
        if not matches:
            raise BatchSpecError(f"{where}: glob '{pattern}' matches nothing (relative to {base})")
        return matches
    if not isinstance(value, list):
        raise BatchSpecError(f"{where}: must be a list of values or {{ glob = \"pattern\" }}, "
                             f"not {type(value).__name__} {value!r}")
    if not value:
        raise BatchSpecError(f"{where}: empty list: give at least one value")
    for v in value:
        if not isinstance(v, (str, int, float, bool)):
            raise BatchSpecError(f"{where}: {v!r} is not a string, number or boolean")
    return [_text(v) for v in value]


def _text(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def run_id(args: tuple[str, ...] | list[str], values: dict[str, str] | None = None) -> str:
    """Stable, readable id: command, first argument, variable values, and a hash of all arguments."""
    digest = hashlib.sha1("\0".join(args).encode()).hexdigest()[:8]
    values = {k: _slug(v) for k, v in (values or {}).items()}
    parts = [args[0]]
    if len(args) > 1 and not args[1].startswith("-") and _slug(args[1]) not in values.values():
        parts.append(_slug(args[1]))
    parts += [f"{k}={v}" for k, v in values.items()]
    name = _UNSAFE.sub("_", "-".join(p for p in parts if p)).strip("._-")[:80]
    return f"{name}-{digest}" if name else digest


def _slug(value: str) -> str:
    """A path is named by its last component; anything else as is (unsafe characters -> '_')."""
    if "/" in value or "\\" in value:
        value = os.path.basename(value.rstrip("/\\")) or value
    return _UNSAFE.sub("_", value)
