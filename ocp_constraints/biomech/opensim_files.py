"""Readers for OpenSim motion and force files and the JW knee-loads exports.

Every reader returns a :class:`Table`: a time array (s), columns by name, and the
unit of each column. Units become SI here, once: angles in radians, translations and
centre-of-pressure coordinates in m, forces in N, moments in N m. Nothing downstream
converts units again.

Supported files

- OpenSim storage files ``.mot`` / ``.sto`` with any of the three header styles: the
  old OpenSim one (``version=1``, ``nRows=``, ``nColumns=``, ``inDegrees=``,
  ``endheader``), the 4.x one (``key=value`` lines, ``endheader``, no row counts) and
  the SIMM one (``name``, ``datacolumns``, ``datarows``, ``range``, ``endheader``;
  SIMM motions are in degrees).
- CSV exports with one header row (the JW ``csv_ngait_og5`` folder).
- MATLAB ``.mat`` trial structs with fields ``data`` and ``colheaders`` (JW).

A malformed file raises :class:`DataFileError` naming the file, the line and the
column (1-based, as an editor shows them).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from .angle_units import angle_unit

#: Pound-force to newton (exact by definition of the lbf).
LBF_TO_N = 4.4482216152605
#: Columns of the JW implant-load file that are in lbf.
KCF_LBF_COLUMNS = ("PM", "AM", "AL", "PL", "medial", "lateral")

_TRANSLATION = re.compile(r"(^|_)t[xyz](_[lr])?$|(^|_)t[xyz]_")


@dataclass
class Table:
    """A time series read from a file, in SI units.

    Attributes
    ----------
    path
        The file it was read from.
    time
        Sample times (s), strictly increasing.
    columns
        Column name -> values (one per sample), SI units.
    units
        Column name -> unit string (``"rad"``, ``"m"``, ``"N"``, ``"N m"``, ...).
    metadata
        Header ``key=value`` pairs and notes on conversions applied.
    """

    path: str
    time: np.ndarray
    columns: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, str | bool] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.column(name)

    def column(self, name: str) -> np.ndarray:
        """Values of ``name``; a :class:`DataFileError` naming the file if it is missing."""
        if name not in self.columns:
            raise DataFileError(self.path, f"has no column '{name}' (columns: {', '.join(self.columns)})")
        return self.columns[name]

    @property
    def names(self) -> list[str]:
        return list(self.columns)


# -- raw parsing -----------------------------------------------------------------------

def _number(token: str, path, line: int, col: int, name: str) -> float:
    try:
        return float(token)
    except ValueError:
        raise DataFileError(path, f"'{token}' in column '{name}' is not a number", line, col) from None


def _rows(lines: list[str], first_line: int, names: list[str], path, sep: str | None) -> np.ndarray:
    data = []
    for k, text in enumerate(lines):
        ln = first_line + k
        if not text.strip():
            continue
        tokens = text.strip().split(sep) if sep else text.split()
        tokens = [t.strip() for t in tokens]
        if sep and tokens and tokens[-1] == "" and len(tokens) == len(names) + 1:
            tokens = tokens[:-1]  # a trailing separator
        if len(tokens) != len(names):
            raise DataFileError(
                path, f"has {len(tokens)} values but the header names {len(names)} columns", ln,
                min(len(tokens), len(names)) + 1,
            )
        data.append([_number(t, path, ln, j + 1, names[j]) for j, t in enumerate(tokens)])
    if not data:
        raise DataFileError(path, "has a header but no data rows")
    return np.asarray(data, dtype=float)


def _read_text(path: Path) -> list[str]:
    try:
        # utf-8-sig: a byte-order mark (Excel's "CSV UTF-8") is not part of the first column's name
        return path.read_text(encoding="utf-8-sig", errors="replace").splitlines()
    except OSError as exc:
        raise DataFileError(path, f"cannot be read: {exc.strerror or exc}") from exc


def _parse_storage(path: Path) -> tuple[list[str], np.ndarray, dict[str, str], int]:
    """Header, labels and data of a .mot/.sto file; returns (names, data, header, label line)."""
    lines = _read_text(path)
    header: dict[str, str] = {}
    end = next((i for i, s in enumerate(lines) if s.strip().lower() == "endheader"), None)
    if end is None:
        raise DataFileError(path, "has no 'endheader' line: not an OpenSim storage file (.mot/.sto)")
    for i, s in enumerate(lines[:end]):
        s = s.strip()
        if "=" in s:
            k, v = s.split("=", 1)
            header[k.strip()] = v.strip()
        elif i == 0 and s:
            header.setdefault("name", s.split(None, 1)[1] if s.lower().startswith("name ") else s)
        elif s:
            parts = s.split(None, 1)
            if parts[0] in ("datacolumns", "datarows", "range", "name"):
                header[parts[0]] = parts[1] if len(parts) > 1 else ""
    label_line = end + 1
    while label_line < len(lines) and not lines[label_line].strip():
        label_line += 1
    if label_line >= len(lines):
        raise DataFileError(path, "has no column labels after 'endheader'", end + 2)
    sep = "\t" if "\t" in lines[label_line] else None
    names = [n.strip() for n in (lines[label_line].strip().split(sep) if sep else lines[label_line].split())]
    names = [n for n in names if n != ""]
    data = _rows(lines[label_line + 1:], label_line + 2, names, path, None)
    for key, expected in (("nRows", data.shape[0]), ("datarows", data.shape[0]),
                          ("nColumns", len(names)), ("datacolumns", len(names))):
        if key in header:
            try:
                declared = int(header[key])
            except ValueError:
                raise DataFileError(path, f"header '{key}={header[key]}' is not an integer") from None
            if declared != expected:
                raise DataFileError(path, f"header says {key}={declared} but the file has {expected}")
    return names, data, header, label_line + 1


def _parse_csv(path: Path) -> tuple[list[str], np.ndarray, dict[str, str], int]:
    lines = _read_text(path)
    first = next((i for i, s in enumerate(lines) if s.strip()), None)
    if first is None:
        raise DataFileError(path, "is empty")
    names = [n.strip() for n in lines[first].split(",")]
    return names, _rows(lines[first + 1:], first + 2, names, path, ","), {}, first + 1


def _parse_mat(path: Path) -> tuple[list[str], np.ndarray, dict[str, str], int]:
    import scipy.io

    try:
        mat = scipy.io.loadmat(str(path), squeeze_me=True, struct_as_record=False)
    except NotImplementedError as exc:   # MATLAB v7.3 (HDF5)
        raise DataFileError(path, f"is a MATLAB v7.3 (HDF5) file, which this reader does not read ({exc}); save it "
                                  "with save(..., '-v7') or export it as .csv") from exc
    except Exception as exc:  # noqa: BLE001 - scipy raises many types for a damaged file (MatReadError, zlib, ...)
        raise DataFileError(path, f"is not a readable MATLAB file ({type(exc).__name__}: {exc or 'no detail'}): "
                                  "damaged, truncated or not a .mat file; save it again from MATLAB (-v7) or "
                                  "export it as .csv") from exc
    structs = [(k, v) for k, v in mat.items() if not k.startswith("__") and hasattr(v, "_fieldnames")]
    good = [(k, v) for k, v in structs if {"data", "colheaders"} <= set(v._fieldnames)]
    if not good:
        raise DataFileError(path, "holds no struct with fields 'data' and 'colheaders'")
    key, s = good[0]
    names = [str(n) for n in np.atleast_1d(s.colheaders)]
    try:
        data = np.atleast_2d(np.asarray(s.data, dtype=float))
    except (TypeError, ValueError) as exc:
        raise DataFileError(path, f"struct '{key}': field 'data' is not a numeric matrix ({exc})") from exc
    if data.ndim != 2:
        raise DataFileError(path, f"struct '{key}': field 'data' must be a 2-D matrix, got shape {data.shape}")
    if data.shape[1] != len(names):
        raise DataFileError(path, f"struct '{key}': data has {data.shape[1]} columns, colheaders {len(names)}")
    header = {"struct": key}
    text = getattr(s, "textdata", None)
    if text is not None:
        for item in np.atleast_1d(np.asarray(text, dtype=object)).ravel():
            if isinstance(item, str) and "=" in item:
                k, v = item.split("=", 1)
                header[k.strip()] = v.strip()
    return names, data, header, 0


def _parse(path) -> tuple[Path, list[str], np.ndarray, dict[str, str], int]:
    p = Path(path)
    if not p.exists():
        raise DataFileError(p, "does not exist")
    suffix = p.suffix.lower()
    if suffix in (".mot", ".sto"):
        names, data, header, label_line = _parse_storage(p)
    elif suffix == ".csv":
        names, data, header, label_line = _parse_csv(p)
    elif suffix == ".mat":
        names, data, header, label_line = _parse_mat(p)
    else:
        raise DataFileError(p, f"has an unknown extension '{p.suffix}' (use .mot, .sto, .csv or .mat)")
    return p, names, data, header, label_line


def _split_time(p: Path, names, data, label_line: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    tcol = next((i for i, n in enumerate(names) if n.lower() in ("time", "t", "time(sec)")), None)
    if tcol is None:
        raise DataFileError(p, f"has no time column (columns: {', '.join(names[:6])} ...)", label_line)
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DataFileError(p, f"names the column(s) {dup} more than once", label_line)
    bad = np.argwhere(~np.isfinite(data))
    if bad.size:
        r, c = (int(x) for x in bad[0])
        line = label_line + 1 + r if label_line else None
        raise DataFileError(p, f"value of '{names[c]}' at t = {data[r, tcol]:g} is {data[r, c]} (not finite)",
                            line, c + 1)
    t = data[:, tcol]
    steps = np.diff(t)
    if np.any(steps <= 0):
        r = int(np.argmax(steps <= 0)) + 1
        raise DataFileError(p, f"time is not strictly increasing at t = {t[r]:g}",
                            label_line + 1 + r if label_line else None, tcol + 1)
    return t, {n: data[:, i] for i, n in enumerate(names) if i != tcol}


def is_translation_name(name: str) -> bool:
    """True for OpenSim's translational coordinate names (``pelvis_tx``, ``knee_ty_l``...).

    State paths such as ``/jointset/knee/knee_tx/value`` are judged by the coordinate.
    """
    parts = [s for s in name.split("/") if s]
    if len(parts) > 1 and parts[-1] in ("value", "speed"):
        name = parts[-2]
    return bool(_TRANSLATION.search(name))


# -- public readers ----------------------------------------------------------------------

def read_motion(path, in_degrees: bool | None = None, translational=None) -> Table:
    """Read joint coordinates (IK output): angles in rad, translations in m.

    Parameters
    ----------
    path
        ``.mot``, ``.sto``, ``.csv`` (JW export, in degrees) or ``.mat`` (JW struct).
    in_degrees
        Override the file's ``inDegrees`` flag (CSV and ``.mat`` exports have none;
        the JW IK exports are in degrees, which is the default for them).
    translational
        Names of translational coordinates (not converted). Default: names ending in
        ``_tx``, ``_ty``, ``_tz`` (optionally followed by ``_l``/``_r``).
    """
    p, names, data, header, label_line = _parse(path)
    t, cols = _split_time(p, names, data, label_line)
    is_trans = (lambda n: n in set(translational)) if translational is not None else is_translation_name
    angles = {n: v for n, v in cols.items() if not is_trans(n) and not n.rstrip("/").endswith("/speed")}
    deg, why, note = angle_unit(p, header, angles, in_degrees)
    units = {}
    for n in cols:
        if is_trans(n):
            units[n] = "m"
        else:
            units[n] = "rad"
            if deg:
                cols[n] = np.deg2rad(cols[n])
    meta = dict(header, angles_converted_from_degrees=bool(deg), in_degrees_source=why)
    if note:
        meta["angle_unit_note"] = note
    return Table(str(p), t, cols, units, meta)


def read_forces(path) -> Table:
    """Read generalized forces (OpenSim ID output) or any table already in SI units.

    Columns ending in ``_moment`` are N m, ``_force`` N; ``inDegrees`` is irrelevant.
    """
    p, names, data, header, label_line = _parse(path)
    t, cols = _split_time(p, names, data, label_line)
    units = {n: "N m" if n.endswith("moment") else "N" if n.endswith("force") else "" for n in cols}
    return Table(str(p), t, cols, units, dict(header))


def read_grf(path) -> Table:
    """Read ground reaction forces of one or more plates (N, m, N m, ground frame).

    ``inDegrees`` in a GRF header is ignored (OpenSim writes ``inDegrees=yes`` into
    force files; no column of such a file is an angle).
    """
    p, names, data, header, label_line = _parse(path)
    t, cols = _split_time(p, names, data, label_line)
    units = {}
    for n in cols:
        kind = _grf_kind(n)
        units[n] = {"force": "N", "point": "m", "torque": "N m"}.get(kind, "")
    table = Table(str(p), t, cols, units, dict(header))
    if not grf_plates(table, strict=False):
        raise DataFileError(p, "has no ground-reaction columns (expected e.g. ground_force_vx or grforce1_fx)")
    return table


def read_implant_loads(path) -> Table:
    """Read the JW measured implant loads (KCF): lbf become N, ``GON`` degrees become rad."""
    p, names, data, header, label_line = _parse(path)
    t, cols = _split_time(p, names, data, label_line)
    units = {}
    for n in cols:
        if n in KCF_LBF_COLUMNS:
            cols[n] = cols[n] * LBF_TO_N
            units[n] = "N"
        elif n == "GON":
            cols[n] = np.deg2rad(cols[n])
            units[n] = "rad"
        else:
            units[n] = "unscaled" if n == "GRFz" else ""
    return Table(str(p), t, cols, units, dict(header, converted="lbf -> N"))


# -- force plates --------------------------------------------------------------------------

def _grf_kind(name: str) -> str | None:
    m = re.match(r"^(?:(\d+)_)?ground_(force|torque)_([vp]?)([xyz])$", name)
    if m:
        return "torque" if m.group(2) == "torque" else ("force" if m.group(3) == "v" else "point")
    m = re.match(r"^grforce(\d+)_([fpt])([xyz])$", name)
    if m:
        return {"f": "force", "p": "point", "t": "torque"}[m.group(2)]
    return None


@dataclass
class Plate:
    """One force plate: force (N), centre of pressure (m), free torque (N m), ground frame."""

    name: str
    force: np.ndarray
    point: np.ndarray
    torque: np.ndarray
    columns: dict[str, str]


def grf_plates(table: Table, strict: bool = True) -> list[Plate]:
    """The plates of a GRF table, in file order.

    Recognizes OpenSim's ``[k_]ground_force_v?, _p?, [k_]ground_torque_?`` and the JW
    ``grforce<k>_f?, _p?, _t?`` naming. With ``strict``, a plate missing one of its nine
    columns is an error naming the file and the column.
    """
    groups: dict[str, dict[str, str]] = {}
    for n in table.columns:
        m = re.match(r"^(?:(\d+)_)?ground_(force|torque)_([vp]?)([xyz])$", n)
        if m:
            plate = f"plate{int(m.group(1)) + 1 if m.group(1) else 1}"
            kind = "torque" if m.group(2) == "torque" else ("force" if m.group(3) == "v" else "point")
            groups.setdefault(plate, {})[f"{kind}_{m.group(4)}"] = n
            continue
        m = re.match(r"^grforce(\d+)_([fpt])([xyz])$", n)
        if m:
            kind = {"f": "force", "p": "point", "t": "torque"}[m.group(2)]
            groups.setdefault(f"plate{m.group(1)}", {})[f"{kind}_{m.group(3)}"] = n
    plates = []
    for name, cols in groups.items():
        need = [f"{k}_{a}" for k in ("force", "point", "torque") for a in "xyz"]
        missing = [k for k in need if k not in cols]
        if missing:
            if strict and not (set(missing) <= {"torque_x", "torque_y", "torque_z"}):
                raise DataFileError(table.path, f"{name}: missing column(s) for {', '.join(missing)}")
        def vec(kind):
            return np.column_stack([table.columns[cols[f"{kind}_{a}"]] if f"{kind}_{a}" in cols
                                    else np.zeros_like(table.time) for a in "xyz"])
        plates.append(Plate(name, vec("force"), vec("point"), vec("torque"), cols))
    return plates


def resample_columns(table: Table, names: list[str], t: np.ndarray) -> np.ndarray:
    """Columns ``names`` at times ``t`` by cubic interpolation (error if ``t`` leaves the data)."""
    from scipy.interpolate import CubicSpline

    lo, hi = table.time[0], table.time[-1]
    tol = 1e-9 * max(1.0, abs(hi))
    if t.min() < lo - tol or t.max() > hi + tol:
        raise DataFileError(table.path, f"covers {lo:g} ... {hi:g} s but {t.min():g} ... {t.max():g} s is needed")
    data = np.column_stack([table.column(n) for n in names])
    return CubicSpline(table.time, data, axis=0)(np.clip(t, lo, hi))


__all__ = ["DataFileError", "Table", "Plate", "read_motion", "read_forces", "read_grf",
           "read_implant_loads", "grf_plates", "is_translation_name", "resample_columns", "LBF_TO_N"
           ]
