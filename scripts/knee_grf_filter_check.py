"""Would low-passing the ground reactions like the coordinates change the knee's inputs? (issue 15, ninth round)

Kristianslund, Krosshaug & van den Bogert 2012 (J Biomech 45:666-671) show that filtering the marker data and the
force-plate data at different cutoffs puts artefacts into the knee moments around impact; they filter both alike.
Our inverse dynamics low-passes the coordinates (3rd-order Butterworth, forward and backward, 6 Hz, as OpenSim's
InverseDynamicsTool) and interpolates the ground reactions unfiltered. This script filters each plate's force and
its moment about the ground origin (`p x F + T`) with the very filter the coordinates get, puts the centre of
pressure back on the plate's plane, runs the inverse dynamics with both, and prints the right leg's generalized
forces by stance window. No contact load is computed: this decides whether the change is worth a candidate.

    python scripts/knee_grf_filter_check.py [--trial ngait_og5] [--cutoff 6] [--out results/knee/grf_filter_check.md]
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import scipy.io as sio

from ocp_constraints.biomech.gait import run_inverse_dynamics
from ocp_constraints.biomech.gait_signals import _opensim_iir, _pad, sample_period
from ocp_constraints.biomech.opensim_files import grf_plates, read_grf

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = DATA / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
ROWS = ["hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "knee_adduction", "ankle_angle"]
WINDOWS = [(2.17, 2.30, "heel strike"), (2.30, 2.45, "loading response"), (2.45, 2.65, "mid-stance"),
           (2.65, 2.92, "terminal stance")]


def lowpass(y: np.ndarray, dt: float, cutoff: float) -> np.ndarray:
    """The coordinates' filter (``gait_signals``): OpenSim's padding, then 3rd-order Butterworth both ways."""
    n = len(y) // 2
    padded = np.column_stack([_pad(y[:, k], n) for k in range(y.shape[1])])
    return _opensim_iir(padded, dt, cutoff)[n:n + len(y)]


def filtered_grf_file(path: Path, cutoff: float, out: Path) -> dict:
    """Write ``path``'s ground reactions low-passed at ``cutoff`` Hz to ``out`` (.mat); return what changed."""
    table = read_grf(path)
    dt = sample_period(table.time)
    columns = {name: np.array(values, float) for name, values in table.columns.items()}
    changes = {}
    for plate in grf_plates(table):
        F, P, T = plate.force, plate.point, plate.torque
        moment = np.cross(P, F) + T                      # about the ground origin: linear in the samples
        Ff, Mf = lowpass(F, dt, cutoff), lowpass(moment, dt, cutoff)
        loaded = np.abs(F[:, 1]) > 50.0
        y0 = float(np.median(P[loaded, 1])) if loaded.any() else 0.0
        ok = np.abs(Ff[:, 1]) > 1.0                      # where the vertical force carries a centre of pressure
        Pn = np.tile([0.0, y0, 0.0], (len(F), 1))
        Pn[ok, 0] = (Mf[ok, 2] + y0 * Ff[ok, 0]) / Ff[ok, 1]
        Pn[ok, 2] = (y0 * Ff[ok, 2] - Mf[ok, 0]) / Ff[ok, 1]
        Tn = Mf - np.cross(Pn, Ff)                       # p x F + T reproduces the filtered moment exactly
        for kind, values in (("force", Ff), ("point", Pn), ("torque", Tn)):
            for k, axis in enumerate("xyz"):
                columns[plate.columns[f"{kind}_{axis}"]] = values[:, k]
        changes[plate.name] = float(np.abs(Ff - F).max())
    headers = ["time"] + list(columns)
    data = np.column_stack([table.time] + list(columns.values()))
    sio.savemat(out, {"GRF": {"data": data, "colheaders": np.array(headers, dtype=object)}})
    return changes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", default="ngait_og5")
    ap.add_argument("--cutoff", type=float, default=6.0)
    ap.add_argument("--out", type=Path, default=Path("results/knee/grf_filter_check.md"))
    args = ap.parse_args()
    subject = DATA / "reducepoly_subject_GC"
    motion = subject / "IK" / f"IK_{args.trial}.mat"
    grf = subject / "GRF" / f"GRF_{args.trial}.mat"
    with tempfile.TemporaryDirectory() as tmp:
        filtered = Path(tmp) / "GRF_filtered.mat"
        changes = filtered_grf_file(grf, args.cutoff, filtered)
        t0, t1 = WINDOWS[0][0], WINDOWS[-1][1]
        before = run_inverse_dynamics(MODEL, motion, grf, t0, t1, cutoff=args.cutoff)
        after = run_inverse_dynamics(MODEL, motion, filtered, t0, t1, cutoff=args.cutoff)
    lines = [f"# Ground reactions low-passed like the coordinates ({args.trial}, {args.cutoff:g} Hz)", "",
             f"`python scripts/knee_grf_filter_check.py --trial {args.trial} --cutoff {args.cutoff:g}`. Issue 15, ninth "
             "round: a check of the inverse dynamics' inputs, no contact load computed. Largest change of a plate's "
             "force by the filter (N): " + ", ".join(f"{k} {v:.1f}" for k, v in changes.items()) + ".", "",
             "Right leg's generalized forces (N m), mean over the window unfiltered -> filtered, and the largest "
             "difference at a frame:", "",
             "| coordinate | " + " | ".join(f"{name} {lo:.2f}-{hi:.2f} s" for lo, hi, name in WINDOWS) + " |",
             "|---|" + "---|" * len(WINDOWS)]
    for row in ROWS:
        i = before.coordinate_names.index(row)
        g0, g1 = before.generalized_forces[:, i], after.generalized_forces[:, i]
        cells = []
        for lo, hi, _ in WINDOWS:
            w = (before.t >= lo) & (before.t < hi)
            cells.append(f"{g0[w].mean():.2f} -> {g1[w].mean():.2f} (max {np.abs(g1[w] - g0[w]).max():.2f})")
        lines.append(f"| {row} | " + " | ".join(cells) + " |")
    text = "\n".join(lines) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
