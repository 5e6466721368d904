"""Preprocessing of the knee (issue 7): fit the JW muscle-tendon lengths to OpenSim's path computation.

Runs :mod:`ocp_constraints.biomech.knee_paths_opensim` with the ``opensim`` package in its own
process (OpenSim and CasADi clash in one process), fits the polynomials of
:mod:`ocp_constraints.biomech.knee_muscles` and writes
``ocp_constraints/biomech/data/jw_knee_muscle_paths.json`` (fits, OpenSim's moment arms on a
knee sweep, hold-out accuracy, the model file's SHA-256), the data that
``data/knee_models.json`` gives to the JW model file. For any other model ``knee`` runs the same
route by itself (:mod:`ocp_constraints.biomech.knee_model_data`) and keeps the result in the
user's cache. Reproducible: fixed seed, 4000 samples (lengths at all, the moment arms of a unit tension
along OpenSim's current path at 1,600 of them, ``knee_paths_opensim.string_moment_arms``; fitted jointly,
:mod:`ocp_constraints.biomech.knee_path_fits`).

    python scripts/knee_muscle_fits.py [--save-raw FILE] [--raw FILE] [--out FILE]

``--save-raw`` keeps OpenSim's sampling (about 100 s of CPU), ``--raw`` fits a sampling kept before, ``--out``
writes the fits elsewhere than the package's data file (to compare before adopting them).
Prints the held-out moment-arm errors against OpenSim's at poses the fit did not use.
"""
import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_model_data import build_muscle_paths, sample_muscle_paths  # noqa: E402
from ocp_constraints.biomech.knee_muscles import DATA_FILE  # noqa: E402

MODEL = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model" / \
    "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--raw", type=Path, help="OpenSim sampling kept before (--save-raw) instead of a new one")
    ap.add_argument("--save-raw", type=Path, help="keep OpenSim's sampling in this file")
    ap.add_argument("--out", type=Path, default=DATA_FILE, help="fits file (default: the package's)")
    args = ap.parse_args()
    raw = json.loads(args.raw.read_text()) if args.raw else sample_muscle_paths(MODEL)
    if args.save_raw:
        args.save_raw.write_text(json.dumps(raw))
    build_muscle_paths(MODEL, args.out, raw=raw)
    data = json.loads(args.out.read_text())
    worst = max(f["holdout_max_length_error_m"] for f in data["unit_fits"].values())
    print(f"wrote {args.out} ({len(data['fits'])} muscles; units with their own length fit: "
          f"{', '.join(data['unit_fits'])}); worst hold-out unit length error {1000 * worst:.3f} mm")
    print("held-out moment arms against OpenSim's (the string's, knee_paths_opensim), 95th percentile / max "
          "(mm; translations: share x 1000):")
    for m, f in data["fits"].items():
        cells = [f"{c} {1000 * e['p95']:.1f}/{1000 * e['max']:.1f}" if e else f"{c} (OpenSim: no finite value)"
                 for c, e in f["holdout_moment_arm_error"].items()]
        print(f"  {m}: force-path length {1000 * f['holdout_max_length_error_m']:.2f} mm; " + ", ".join(cells))
