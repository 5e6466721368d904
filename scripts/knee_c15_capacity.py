"""Issue 15, candidate C15 (preregistered, reported only): C13 with the muscles' active force-length-velocity capacity.

    python scripts/knee_c15_capacity.py --data <ReducePoly_forMSK at 0b5ecfa>/ExampleTrackingSimulations/OpenSimModel/subject_GC
        [--out results/knee/c15_capacity.md]

Each muscle's force is ``a F0 f_L f_V cos(alpha)`` (``knee --muscle-model hill``'s capacities: De Groote et
al. 2016 curves, rigid tendon, the length scaling of ``knee_hill.py``) with the passive fibre force set to zero,
because C7's passive moments (Riener & Edrich 1999) already contain it (the form of C11;
``results/knee/preregistration.md``, fourth round). Everything else is C13, the default. Runs ngait_og5, bouncy7
and mtpgait3 and writes RMSE / R^2 / peak error per compartment beside C13's, the peak reserves and, at each
trial's total-load peak, the largest muscle forces. Nothing is fitted to the measured loads.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import ocp_constraints.biomech.knee_hill as knee_hill  # noqa: E402
from ocp_constraints.biomech.knee_pipeline import run_knee  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED  # noqa: E402

MODEL = (ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model"
         / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim")
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")
_hill_forces = knee_hill.hill_forces


def active_only(*args, **kwargs):
    """``hill_forces`` without the fibres' passive force (C7's passive moments contain it)."""
    h = _hill_forces(*args, **kwargs)
    h.passive = np.zeros_like(h.passive)
    return h


def row(trial, name, run) -> str:
    c, res = run["comparison"], run["result"]
    cells = [f"{c[k]['rmse_bw']:.2f} / {c[k]['r2']:.2f} / {c[k]['peak_error_bw']:+.2f}" for k in ("medial", "lateral", "total")]
    reserves = ", ".join(f"{v:.1f}" for v in np.abs(res.reserve).max(0))
    i = int(np.argmax(res.total))
    top = np.argsort(-res.force[i])[:4]
    forces = ", ".join(f"{res.muscles[j]} {res.force[i, j]:.0f}" for j in top)
    return f"| {trial} | {name} | " + " | ".join(cells) + f" | {reserves} | {res.t[i]:.3f} s: {forces} |"


def main(data: Path, out: Path) -> None:
    clock, cpu = time.perf_counter(), time.process_time()
    lines = ["| trial | model | medial RMSE / R^2 / peak error | lateral | total | peak reserves (N m; "
             + ", ".join(RESERVED) + ") | largest muscle forces (N) at the total's peak |", "|---|---|---|---|---|---|---|"]
    for trial in TRIALS:
        files = [data / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")]
        knee_hill.hill_forces = _hill_forces
        lines.append(row(trial, "C13 (default)", run_knee(MODEL, *files, method="static")))
        print(lines[-1], flush=True)
        knee_hill.hill_forces = active_only
        try:
            lines.append(row(trial, "C15 (C13 + active force-length-velocity capacity)",
                             run_knee(MODEL, *files, muscle_model="hill", method="static")))
        finally:
            knee_hill.hill_forces = _hill_forces
        print(lines[-1], flush=True)
    text = ("# C15: C13 with the muscles' active force-length-velocity capacity (reported only)\n\n"
            "`python scripts/knee_c15_capacity.py --data <ReducePoly_forMSK at 0b5ecfa>/ExampleTrackingSimulations/"
            "OpenSimModel/subject_GC`; static optimisation; RMSE and peak error in BW, R^2 = 1 - SSE/SST. "
            "Preregistered in `preregistration.md` (fourth round).\n\n" + "\n".join(lines) + "\n")
    out.write_text(text)
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="folder with IK/, GRF/, KCF/ of the JW trials (.mat)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee" / "c15_capacity.md")
    args = ap.parse_args()
    main(args.data, args.out)
