"""Issue 15: the knee model on JW trials it was not chosen on (bouncy7, mtpgait3) beside ngait_og5.

    git clone https://github.com/gilserrancoli/ReducePoly_forMSK R && git -C R checkout 0b5ecfa
    python scripts/knee_check_trials.py --data R/ExampleTrackingSimulations/OpenSimModel/subject_GC [--out results/knee]

``--data`` holds ``IK/IK_<trial>.mat``, ``GRF/GRF_<trial>.mat`` and ``KCF/KCF_<trial>.mat`` (the folder our
ngait_og5 files were copied from; its ngait_og5 files are byte-identical to ours). Every trial is run with the
same model and settings (``results/knee/preregistration.md``, "Check trials"): C0 (``--passive-hip none
--quadriceps model-paths``), C7 (``--quadriceps model-paths``), C13 (static), C13 with activation dynamics (``--method collocation``, the default since rule C17) and C14 (reported only:
C13 plus the extension stop as posterior-capsule tension ``T = exp(2.220 - 0.150 K) / rho``, ``rho`` the
implant's condyle radius; the tension only adds ``T`` along the tray axis, so the muscles' solution is C13's
and each compartment gains ``T/2``, which is what is computed here). The default's run of each trial is written to
``<out>/check/<trial>/`` (the ``knee`` command's files and figure). Writes ``<out>/check_trials.md``: RMSE
(BW), R^2 and peak error (BW) per compartment. Nothing is fitted to, or chosen by, these loads.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_contact import stored_geometry  # noqa: E402
from ocp_constraints.biomech.knee_pipeline import compare, run_knee, write_knee_results  # noqa: E402

MODEL = (ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model"
         / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim")
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")
VARIANTS = {"C0 before (no passive moments, model's quadriceps paths), static":
            {"passive_hip": "none", "quadriceps": "model-paths", "method": "static"},
            "C7 (Riener & Edrich hip, knee, ankle), static": {"quadriceps": "model-paths", "method": "static"},
            "C13 (C7 + quadriceps through the patellar ligament; adopted), static": {"method": "static"},
            "**C13 with activation dynamics (collocation; the default by rule C17)**": {"method": "collocation"}}
C14_FROM = "C13 (C7 + quadriceps through the patellar ligament; adopted), static"


def cell(c: dict) -> str:
    return f"{c['rmse_bw']:.2f} / {c['r2']:.2f} / {c['peak_error_bw']:+.2f}"


def main(data: Path, out: Path) -> None:
    clock, cpu = time.perf_counter(), time.process_time()
    rho = 0.5 * sum(stored_geometry()[f"{s}_radius"] for s in ("medial", "lateral"))
    lines = ["| trial | model | medial RMSE / R^2 / peak error | lateral RMSE / R^2 / peak error | "
             "total RMSE / R^2 / peak error | measured peaks medial / lateral / total |", "|---|---|---|---|---|---|"]
    for trial in TRIALS:
        files = [data / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")]
        runs = {}
        for name, opts in VARIANTS.items():
            run = runs[name] = run_knee(MODEL, *files, **opts)
            c = run["comparison"]
            peaks = " / ".join(f"{c[k]['peak_measured_bw']:.2f}" for k in ("medial", "lateral", "total"))
            lines.append(f"| {trial} | {name} | " + " | ".join(cell(c[k]) for k in ("medial", "lateral", "total"))
                         + f" | {peaks} |")
            print(lines[-1], flush=True)
        # C14 from the C13 static run: the capsule tension adds T/2 to each compartment (module docstring)
        base = runs[C14_FROM]
        g, r = base["gait"], base["result"]
        K = -np.degrees(g.states["p"][:, g.coordinate_names.index("knee_flexion")])
        half = 0.5 * np.exp(2.220 - 0.150 * K) / rho
        c = compare(r.t, {"medial": r.medial + half, "lateral": r.lateral + half, "total": r.total + 2 * half},
                    base["measured"], base["bw"])
        lines.append(f"| {trial} | C14 (C13 + extension stop as capsule tension; reported only) | "
                     + " | ".join(cell(c[k]) for k in ("medial", "lateral", "total")) + " | |")
        print(lines[-1], flush=True)
        # the default's run (the last variant) with its files and figure
        write_knee_results(run, out / "check" / trial, inputs={"model": str(MODEL), "motion": str(files[0]),
                                                                 "grf": str(files[1]), "measured": str(files[2])})
    text = ("# The knee model on JW trials it was not chosen on\n\n`python scripts/knee_check_trials.py --data "
            "<ReducePoly_forMSK at 0b5ecfa>/ExampleTrackingSimulations/OpenSimModel/subject_GC`; static "
            "optimisation, and the default (C13 with activation dynamics by direct collocation); RMSE and peak error in BW, R^2 = 1 - SSE/SST. bouncy7 is a bouncy gait, mtpgait3 a "
            "medial-thrust gait (a modification that unloads the medial compartment). The default's runs and figures: "
            "`check/<trial>/`.\n\n" + "\n".join(lines) + "\n")
    (out / "check_trials.md").write_text(text)
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="folder with IK/, GRF/, KCF/ of the JW trials (.mat)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    args = ap.parse_args()
    main(args.data, args.out)
