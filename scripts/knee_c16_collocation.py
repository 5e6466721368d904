"""Issue 15, candidate C16 (preregistered, reported only): C13 with activation dynamics (direct collocation).

    python scripts/knee_c16_collocation.py --data <ReducePoly_forMSK at 0b5ecfa>/ExampleTrackingSimulations/OpenSimModel/subject_GC
        [--out results/knee/c16_collocation.md]

Runs ngait_og5, bouncy7 and mtpgait3 with the default model (C13) by static optimisation and by direct
collocation with first-order activation dynamics (``knee --method collocation``: Raasch et al. 1997,
15 / 60 ms), and writes RMSE / R^2 / peak error per compartment, the peak reserves and the wall and CPU time of
each run (``results/knee/preregistration.md``, C16). Nothing is fitted to the measured loads.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # as the knee command (cli/knee.py), before NumPy loads
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_pipeline import run_knee  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED  # noqa: E402

MODEL = (ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model"
         / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim")
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")


def main(data: Path, out: Path) -> None:
    lines = ["| trial | method | medial RMSE / R^2 / peak error | lateral | total | peak reserves (N m; "
             + ", ".join(RESERVED) + ") | wall / CPU (s) |", "|---|---|---|---|---|---|---|"]
    for trial in TRIALS:
        files = [data / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")]
        for method in ("static", "collocation"):
            clock, cpu = time.perf_counter(), time.process_time()
            run = run_knee(MODEL, *files, method=method)
            wall, used = time.perf_counter() - clock, time.process_time() - cpu
            c, res = run["comparison"], run["result"]
            cells = [f"{c[k]['rmse_bw']:.2f} / {c[k]['r2']:.2f} / {c[k]['peak_error_bw']:+.2f}"
                     for k in ("medial", "lateral", "total")]
            reserves = ", ".join(f"{v:.1f}" for v in np.abs(res.reserve).max(0))
            lines.append(f"| {trial} | {method} | " + " | ".join(cells) + f" | {reserves} | {wall:.1f} / {used:.1f} |")
            print(lines[-1], flush=True)
    out.write_text("# C16: C13 with activation dynamics (direct collocation), reported only\n\n"
                   "`python scripts/knee_c16_collocation.py --data <ReducePoly_forMSK at 0b5ecfa>/"
                   "ExampleTrackingSimulations/OpenSimModel/subject_GC`; RMSE and peak error in BW, R^2 = 1 - SSE/SST. "
                   "Preregistered in `preregistration.md` (C16).\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="folder with IK/, GRF/, KCF/ of the JW trials (.mat)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee" / "c16_collocation.md")
    args = ap.parse_args()
    main(args.data, args.out)
