"""Preprocessing of the knee (issue 7): fit the JW muscle-tendon lengths to OpenSim's path computation.

Runs :mod:`ocp_constraints.biomech.knee_paths_opensim` with the ``opensim`` package in its own
process (OpenSim and CasADi clash in one process), fits the polynomials of
:mod:`ocp_constraints.biomech.knee_muscles` and writes
``ocp_constraints/biomech/data/jw_knee_muscle_paths.json`` (fits, OpenSim's moment arms on a
knee sweep, hold-out accuracy, the model file's SHA-256), the data that
``data/knee_models.json`` gives to the JW model file. For any other model ``knee`` runs the same
route by itself (:mod:`ocp_constraints.biomech.knee_model_data`) and keeps the result in the
user's cache. Reproducible: fixed seed, 4000 samples. Usage: ``python scripts/knee_muscle_fits.py``.
"""
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_model_data import build_muscle_paths  # noqa: E402
from ocp_constraints.biomech.knee_muscles import DATA_FILE  # noqa: E402

MODEL = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model" / \
    "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"

if __name__ == "__main__":
    build_muscle_paths(MODEL, DATA_FILE)
    data = json.loads(DATA_FILE.read_text())
    worst = max(f["holdout_max_length_error_m"] for f in [*data["fits"].values(), *data["unit_fits"].values()])
    print(f"wrote {DATA_FILE} ({len(data['fits'])} muscles); worst hold-out length error {1000 * worst:.3f} mm")
