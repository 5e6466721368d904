"""Preprocessing for issue 7: fit the JW muscle-tendon lengths to OpenSim's path computation.

Runs ``knee_muscle_paths_opensim.py`` with the ``opensim`` package in its own process
(OpenSim and CasADi clash in one process), fits the polynomials of
:mod:`ocp_constraints.biomech.knee_muscles` and writes ``ocp_constraints/biomech/data/jw_knee_muscle_paths.json``
(fits, OpenSim's moment arms on a knee sweep, hold-out accuracy), and the lengths of the
quadriceps' muscle-tendon units (the model's ``<name>_withreallength`` paths ending on the
patella; ``unit_fits``). Reproducible: fixed
seed, 4000 samples. Usage: ``python scripts/knee_muscle_fits.py [MODEL.osim]``.
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_muscles import DATA_FILE, fit_paths, fit_units  # noqa: E402

MODEL = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model" / \
    "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"


def main(model=MODEL, samples=4000, seed=7):
    with tempfile.TemporaryDirectory() as tmp:
        raw_path = Path(tmp) / "raw.json"
        proc = subprocess.run([sys.executable, str(Path(__file__).with_name("knee_muscle_paths_opensim.py")),
                               str(model), str(raw_path), str(samples), str(seed)], capture_output=True, text=True)
        if proc.returncode != 0:
            sys.exit(f"OpenSim run failed:\n{proc.stderr[-3000:]}")
        raw = json.loads(raw_path.read_text())
    fits = fit_paths(raw)
    units = fit_units(raw)
    out = {"source": "OpenSim path lengths (scripts/knee_muscle_paths_opensim.py), polynomial fits "
                     "(ocp_constraints/knee_muscles.py)",
           "opensim_version": raw["opensim_version"], "model": Path(str(model)).name, "samples": samples,
           "seed": seed, "knee_ty": raw["knee_ty"], "patella_coupling": raw["patella_coupling"],
           "fits": fits, "unit_suffix": raw["unit_suffix"], "unit_fits": units,
           "sweep_knee_flexion": raw["sweep_knee_flexion"], "sweep_muscles": raw["muscles"],
           "sweep_moment_arms_opensim": raw["sweep_moment_arms"],
           "sweep_moment_arm_knee_fd_coupled_opensim": raw["sweep_moment_arm_knee_fd_coupled"]}
    DATA_FILE.parent.mkdir(parents=True, exist_ok=True)
    DATA_FILE.write_text(json.dumps(out))
    worst = max(f["holdout_max_length_error_m"] for f in [*fits.values(), *units.values()])
    print(f"wrote {DATA_FILE} ({len(fits)} muscles); worst hold-out length error {1000 * worst:.3f} mm")


if __name__ == "__main__":
    main(*sys.argv[1:2])
