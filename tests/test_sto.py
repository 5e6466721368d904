"""OpenSim storage files (.sto) beside the CSV results.

Written by :mod:`ocp_constraints.output.sto` for every simulation, optimal-control, gait and knee
run; read back with our OpenSim reader (:mod:`ocp_constraints.biomech.opensim_files`) and, when the
optional ``opensim`` package is installed, with OpenSim 4.6 itself (``opensim.TimeSeriesTable``
and ``opensim.Storage``, the GUI's loader) in its own process (its wheel bundles its own CasADi).
The values are compared with the CSV files read by NumPy, a reading path of its own.
"""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.biomech.opensim_files import read_forces, read_motion
from ocp_constraints.errors import OcpConstraintsError
from ocp_constraints.output.sto import sto_text, write_sto

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
G = DATA / "opensim-gait2354-subject01"
J = DATA / "grand-challenge-knee-jw"
HAS_OPENSIM = importlib.util.find_spec("opensim") is not None


def _csv(path: Path) -> tuple[list[str], np.ndarray]:
    names = path.read_text().splitlines()[0].split(",")
    return names, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_header_is_opensims_storage_version_1():
    text = sto_text([0.0, 0.5], {"a.theta": [1.0, 2.0], "F@b.F_x": [3.0, 4.0]}, name="loads")
    assert text.splitlines()[:7] == ["loads", "version=1", "nRows=2", "nColumns=3", "inDegrees=no", "endheader",
                                     "time\ta.theta\tF@b.F_x"]
    assert text.splitlines()[7].split("\t") == ["0", "1", "3"]


def test_our_reader_reads_back_every_digit_and_keeps_radians(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.001, 0.01, 50))
    cols = {"pelvis_tilt": rng.normal(size=50), "hip_flexion_r": rng.normal(size=50), "knee.F_x": rng.normal(size=50)}
    write_sto(tmp_path / "x.sto", t, cols)
    back = read_forces(tmp_path / "x.sto")
    assert np.array_equal(back.time, t)
    assert list(back.columns) == list(cols) and all(np.array_equal(back.columns[k], v) for k, v in cols.items())
    motion = read_motion(tmp_path / "x.sto")                  # inDegrees=no: the angles stay radians
    assert np.array_equal(motion.columns["hip_flexion_r"], cols["hip_flexion_r"])


@pytest.mark.parametrize("t, cols, words", [
    ([0.0, 0.0], {"a": [1, 2]}, "times must increase strictly"),
    ([0.0, 1.0], {"time": [1, 2]}, "not 'time'"),
    ([0.0, 1.0], {"a\tb": [1, 2]}, "without tabs"),
    ([0.0, 1.0], {"a": [1, 2, 3]}, "needs 2 values"),
])
def test_bad_columns_are_refused_with_the_reason(t, cols, words):
    with pytest.raises((OcpConstraintsError, ValueError), match=words):
        sto_text(t, cols)


@pytest.fixture(scope="module")
def whirling_run(tmp_path_factory):
    from ocp_constraints.cli.main import main

    out = tmp_path_factory.mktemp("whirling")
    assert main(["simulate", "whirling", "--t-final", "0.5", "--out", str(out), "--no-plots"]) == 0
    return out


@pytest.mark.parametrize("stem", ["trajectory", "loads"])
def test_simulation_writes_sto_equal_to_its_csv(whirling_run, stem):
    names, data = _csv(whirling_run / f"{stem}.csv")
    tab = read_forces(whirling_run / f"{stem}.sto")
    assert ["t", *tab.columns] == names
    assert np.array_equal(tab.time, data[:, 0])
    assert all(np.array_equal(tab.columns[n], data[:, i + 1]) for i, n in enumerate(names[1:]))


OPENSIM_READ = r"""
import json, sys
import opensim as osim
osim.Logger.removeFileSink()   # else OpenSim writes opensim.log beside the model (in shared data)
out = {}
for path in sys.argv[1:]:
    table = osim.TimeSeriesTable(path)
    labels = list(table.getColumnLabels())
    storage = osim.Storage(path)
    out[path] = {"labels": labels, "rows": table.getNumRows(), "time": list(table.getIndependentColumn()),
                 "in_degrees": table.getTableMetaDataAsString("inDegrees"),
                 "columns": {n: list(table.getDependentColumn(n).to_numpy()) for n in labels},
                 "storage_rows": storage.getSize(), "storage_in_degrees": storage.isInDegrees(),
                 "storage_labels": [storage.getColumnLabels().get(i) for i in range(storage.getColumnLabels().getSize())]}
print(json.dumps(out))
"""


def _opensim_read(*paths: Path) -> dict:
    proc = subprocess.run([sys.executable, "-c", OPENSIM_READ, *map(str, paths)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not HAS_OPENSIM, reason="the optional 'opensim' package (OpenSim 4.6) is not installed")
def test_opensim_reads_our_sto_files(whirling_run):
    paths = [whirling_run / "trajectory.sto", whirling_run / "loads.sto"]
    seen = _opensim_read(*paths)
    for p in paths:
        got = seen[str(p)]
        names, data = _csv(p.with_suffix(".csv"))
        assert got["labels"] == names[1:] and got["rows"] == len(data)
        assert got["in_degrees"] == "no" and got["storage_in_degrees"] is False
        assert got["storage_rows"] == len(data) and got["storage_labels"] == ["time", *names[1:]]
        assert np.array_equal(got["time"], data[:, 0])
        for i, n in enumerate(names[1:]):
            assert np.array_equal(got["columns"][n], data[:, i + 1]), n


@pytest.mark.skipif(not (G / "subject01_walk1_ik.mot").is_file(), reason="shared gait2354 data not found")
def test_gait_trajectory_sto_is_a_motion_of_the_model(tmp_path):
    """trajectory.sto of ``gait`` holds the model's coordinates by their OpenSim names, in radians
    (inDegrees=no): the filtered ones the inverse dynamics used. Against the raw IK file (degrees)
    they differ by the 6 Hz low-pass only (up to 1.5 degrees at the knee around heel strike; the
    filter itself is tested in test_gait.py); a file left in degrees would be 57 times off."""
    from ocp_constraints.cli.main import main

    out = tmp_path / "gait"
    assert main(["gait", "--model", str(G / "subject01_simbody.osim"), "--motion", str(G / "subject01_walk1_ik.mot"),
                 "--grf", str(G / "subject01_walk1_grf.mot"), "--out", str(out), "--no-plots"]) == 0
    traj = read_motion(out / "trajectory.sto")
    raw = read_motion(G / "subject01_walk1_ik.mot")              # degrees in the file, radians once read
    assert set(traj.columns) == set(raw.columns)
    for c in ("hip_flexion_r", "knee_angle_r", "ankle_angle_r"):
        ref = np.interp(traj.time, raw.time, raw.columns[c])
        assert np.abs(traj.columns[c] - ref).max() < np.radians(2.0)
    loads = read_forces(out / "loads.sto")
    names, data = _csv(out / "loads.csv")
    assert np.array_equal(loads.columns["knee_angle_r_moment"], data[:, names.index("knee_angle_r_moment")])
    if HAS_OPENSIM:
        seen = _opensim_read(out / "trajectory.sto")[str(out / "trajectory.sto")]
        assert set(seen["labels"]) == set(raw.columns) and seen["in_degrees"] == "no"


@pytest.mark.skipif(not (J / "reducepoly_subject_GC").is_dir(), reason="shared JW knee data not found")
def test_knee_writes_loads_and_muscle_forces_sto(tmp_path):
    import scipy.io

    from ocp_constraints.cli.main import main

    mat = scipy.io.loadmat(str(J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat"), squeeze_me=True,
                           struct_as_record=False)
    s = next(v for key, v in mat.items() if not key.startswith("__"))
    motion = tmp_path / "ik_15hz.csv"                              # every 8th frame: a small problem
    motion.write_text(",".join(map(str, s.colheaders)) + "\n"
                      + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in np.asarray(s.data, float)[::8]))
    out = tmp_path / "knee"
    model = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
    assert main(["knee", "--model", str(model), "--motion", str(motion), "--grf",
                 str(J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat"), "--out", str(out), "--no-plots"]) == 0
    names, data = _csv(out / "loads.csv")
    forces = read_forces(out / "muscle_forces.sto")
    muscles = [n[: -len(".force")] for n in names if n.endswith(".force")]
    assert list(forces.columns) == muscles and len(muscles) > 10
    for m in muscles:
        assert np.array_equal(forces.columns[m], data[:, names.index(f"{m}.force")])
    assert np.array_equal(read_forces(out / "loads.sto").time, data[:, 0])
    if HAS_OPENSIM:
        seen = _opensim_read(out / "muscle_forces.sto", out / "loads.sto")
        assert seen[str(out / "muscle_forces.sto")]["labels"] == muscles
        assert seen[str(out / "loads.sto")]["rows"] == len(data)
