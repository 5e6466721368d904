"""Degrees or radians: what a motion file's header says, checked against the range of its angles.

Used by :func:`.opensim_files.read_motion`. A header that says one unit while the values can
only be the other is a :class:`DataFileError` that says so; a file without an ``inDegrees``
line (OpenSim storage files without one: radians; the JW ``.csv``/``.mat`` exports: degrees)
is read in the unit its range shows, with a note that says so.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataFileError

#: Angle columns that may hold a global offset (a free joint's rotations: the subject's heading).
GLOBAL_ANGLES = 3


def _in_degrees(header: dict[str, str], override: bool | None) -> tuple[bool, str]:
    if override is not None:
        return override, "given by the caller"
    if "inDegrees" in header:
        return header["inDegrees"].strip().lower() in ("yes", "true", "1"), "header inDegrees"
    if "datacolumns" in header or "datarows" in header:
        return True, "SIMM header (SIMM motions are in degrees)"
    return False, "no inDegrees in header: assumed radians"


def angle_unit(p: Path, header: dict[str, str], angles: dict[str, np.ndarray],
               in_degrees: bool | None) -> tuple[bool, str, str | None]:
    """``(in degrees?, why, note)`` for the angle columns ``angles`` of the file ``p``."""
    note = None
    if in_degrees is None and p.suffix.lower() in (".csv", ".mat") and "inDegrees" not in header:
        deg, why = True, "no header: the JW .csv/.mat exports are in degrees"    # SOURCE.md
    else:
        deg, why = _in_degrees(header, in_degrees)
    verdict = angle_unit_from_range(angles) if in_degrees is None else None
    if verdict is not None and (verdict == "degrees") != deg:
        if verdict == "degrees":
            big = max(angles, key=lambda n: float(np.abs(angles[n]).max()))
            evidence = f"'{big}' reaches {float(np.abs(angles[big]).max()):.4g}, and no joint angle in radians exceeds 2 pi"
        else:
            big = max(angles, key=lambda n: float(np.ptp(angles[n])))
            evidence = (f"'{big}' moves by {float(np.ptp(angles[big])):.4g} and no angle by more than pi: in degrees "
                        f"every joint would move within 3.2 degrees")
        if why == "header inDegrees":
            said = "inDegrees=yes" if deg else "inDegrees=no"
            raise DataFileError(p, f"says {said} in its header, but its angles look like {verdict} ({evidence}): "
                                   f"correct the header's inDegrees line (or read it with in_degrees="
                                   f"{verdict == 'degrees'})")
        deg = verdict == "degrees"
        note = (f"{p.name}: no inDegrees line in the header ({why}), but the angles' "
                f"range says {verdict} ({evidence}): read as {verdict}")
        why = "range of the angles"
    return deg, why, note


def angle_unit_from_range(angles: dict[str, np.ndarray]) -> str | None:
    """``"degrees"``, ``"radians"`` or None (can't tell) from the values of the angle columns.

    Degrees: some angle exceeds 2 pi in magnitude (no joint angle in radians does: more than
    a full turn). Radians: every column moves by at most pi (no joint turns by more than half a turn
    in a trial) while some column moves by more than 0.35 (20 degrees if radians; in degrees every
    joint would stay within 3.2 degrees while one moves by a third of a degree, which no recorded
    motion of a person with that many columns looks like), and every angle stays within pi in
    magnitude but at most :data:`GLOBAL_ANGLES` columns, fewer than half of them: a free joint's three
    rotations carry the subject's heading, which is near pi for one walking along -x (one such
    trial, in radians and labelled degrees, was read as degrees). Anything between: None.
    """
    if not angles:
        return None
    peaks = np.array([float(np.abs(v).max()) for v in angles.values()])
    moves = np.array([float(np.ptp(v)) for v in angles.values()])
    if peaks.max() > 2 * np.pi:
        return "degrees"
    beyond = int(np.sum(peaks > np.pi))
    if 0.35 < moves.max() <= np.pi and beyond <= GLOBAL_ANGLES and 2 * beyond < len(peaks):
        return "radians"
    return None
