"""Gait trials with another frontal-plane (varus-valgus) alignment of the right knee, for a sensitivity batch.

    python scripts/knee_alignment_motions.py IK.csv MODEL.osim OUT_DIR -3 0 3

writes ``OUT_DIR/<stem>_varus<+a>deg.csv`` for every angle ``a`` (degrees): the trial's coordinates
with the right knee in ``a`` degrees of varus (``knee_adduction``, the JW knee's frontal-plane
angle, locked in the model and 0 throughout the gait data, set to ``a``: it turns the distal
tibia medially) and the hip abducted by the angle ``b`` that keeps the foot where it was
(``hip_adduction - b``, ``b = a s_k / s_h`` with ``s_k``, ``s_h`` the medio-lateral motion of the
calcaneus per degree of knee and of hip adduction in the model's neutral pose). So the knee
moves laterally of the hip-ankle line while the foot stays on the measured centre of pressure:
a varus knee (``a > 0``) or a valgus one (``a < 0``) under the same ground reactions, as a
malaligned limb is modelled by Lerner et al. (2015, J Biomech 48:644). The knee command runs
its inverse dynamics on that leg and evaluates the condyle contact directions at that angle.
Only the JW comma-separated IK format (header row, degrees) is handled.
"""
from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

KNEE, HIP = "knee_adduction", "hip_adduction"
FOOT = "calcaneus"


def hip_compensation(model: str | Path) -> float:
    """Degrees of hip adduction per degree of knee adduction that keep the calcaneus's
    medio-lateral position (neutral pose, right leg)."""
    from ocp_constraints.biomech.osim_model import load_osim

    osim = load_osim(model)
    p0 = {c: 0.0 for c in osim.coordinate_names}

    def foot_z(**deg) -> float:
        p = {**p0, **{k: np.radians(v) for k, v in deg.items()}}
        return float(np.asarray(osim.poses(p)[FOOT][1]).ravel()[2])

    base = foot_z()
    return -(foot_z(**{KNEE: 1.0}) - base) / (foot_z(**{HIP: 1.0}) - base)


def write_variants(ik: Path, model: Path, out: Path, angles_deg: list[float]) -> list[Path]:
    with open(ik, newline="") as fh:
        rows = list(csv.reader(fh))
    header, data = rows[0], rows[1:]
    missing = [c for c in (KNEE, HIP) if c not in header]
    if missing:
        raise SystemExit(f"{ik}: no column(s) {missing} (a JW-type IK .csv with a header row is needed)")
    k, h = header.index(KNEE), header.index(HIP)
    ratio = hip_compensation(model)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for a in angles_deg:
        path = out / f"{ik.stem}_varus{a:+g}deg.csv"
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(header)
            for r in data:
                r = list(r)
                r[k] = repr(float(a))
                r[h] = repr(float(r[h]) + ratio * a)
                w.writerow(r)
        written.append(path)
    print(f"hip adduction {ratio:+.4f} deg per degree of varus keeps the foot in place", file=sys.stderr)
    return written


if __name__ == "__main__":
    if len(sys.argv) < 5:
        raise SystemExit(__doc__)
    for p in write_variants(Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]), [float(a) for a in sys.argv[4:]]):
        print(p)
