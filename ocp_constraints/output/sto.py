"""OpenSim storage files (``.sto``) beside the CSV results, for the OpenSim GUI, Moco and
``opensim.TimeSeriesTable``.

The format is OpenSim's storage version 1 (the one its tools have written since 2.x and
every OpenSim 4 reader accepts):

    <name>
    version=1
    nRows=<rows>
    nColumns=<columns, time included>
    inDegrees=no
    endheader
    time<TAB><label><TAB>...
    <rows, tab-separated, full double precision>

Angles in our results are radians, so ``inDegrees=no``. Labels are the CSV's column names
(OpenSim coordinate names for gait kinematics, so the GUI matches them to a model's
coordinates). Written whole through :func:`~ocp_constraints.output.files.write_atomic`.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..errors import OcpConstraintsError
from .files import write_atomic


def sto_text(t, columns: dict[str, np.ndarray], name: str = "ocp_constraints", in_degrees: bool = False) -> str:
    """The storage file's text: header, ``time`` and one column per entry of ``columns`` (SI units)."""
    t = np.asarray(t, dtype=float).ravel()
    labels = list(columns)
    bad = [c for c in ["time", *labels] if not c or any(ch in c for ch in "\t\r\n")]
    if bad or "time" in labels:
        raise OcpConstraintsError(f".sto '{name}': column labels must be non-empty, without tabs or line breaks, and "
                                  f"not 'time' (the first column); got {bad or ['time']}")
    values = [np.asarray(v, dtype=float).ravel() for v in columns.values()]
    short = [k for k, v in zip(labels, values) if v.size != t.size]
    if short:
        raise OcpConstraintsError(f".sto '{name}': every column needs {t.size} values (one per time); "
                                  f"{short[:5]} have other lengths")
    data = np.column_stack([t] + values)
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise OcpConstraintsError(f".sto '{name}': times must increase strictly (OpenSim's TimeSeriesTable "
                                  "refuses anything else)")
    head = [name.replace("\n", " ") or "ocp_constraints", "version=1", f"nRows={data.shape[0]}",
            f"nColumns={data.shape[1]}", f"inDegrees={'yes' if in_degrees else 'no'}", "endheader",
            "\t".join(["time", *labels])]
    buf = io.StringIO()
    np.savetxt(buf, data, delimiter="\t", fmt="%.17g")
    return "\n".join(head) + "\n" + buf.getvalue()


def write_sto(path: str | Path, t, columns: dict[str, np.ndarray], name: str | None = None,
              in_degrees: bool = False) -> None:
    """Write ``columns`` (name -> values at ``t``, s) as an OpenSim storage file (see module docs)."""
    path = Path(path)
    write_atomic(path, sto_text(t, columns, name or path.stem, in_degrees).encode())
