"""Readers of OpenSim and JW data files: real shared files and malformed ones."""
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.errors import OcpConstraintsError
from ocp_constraints.biomech.opensim_files import LBF_TO_N, grf_plates, read_forces, read_grf, read_implant_loads, read_motion
from ocp_constraints.errors import DataFileError

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
G = DATA / "opensim-gait2354-subject01"
J = DATA / "grand-challenge-knee-jw"


def test_old_header_in_degrees_converted_translations_kept():
    m = read_motion(G / "subject01_walk1_ik.mot")
    assert len(m.time) == 73 and m.time[0] == pytest.approx(0.4) and m.time[-1] == pytest.approx(1.6)
    # first row of the file: knee_angle_r -55.24623342 deg, pelvis_tx 0.60162386 m
    assert m["knee_angle_r"][0] == pytest.approx(np.deg2rad(-55.24623342), abs=1e-12)
    assert m["pelvis_tx"][0] == pytest.approx(0.60162386, abs=1e-12)
    assert m.units["pelvis_tx"] == "m" and m.units["knee_angle_r"] == "rad"


def test_grf_file_with_indegrees_yes_is_not_converted_and_has_two_plates():
    g = read_grf(G / "subject01_walk1_grf.mot")
    plates = grf_plates(g)
    assert [p.name for p in plates] == ["plate1", "plate2"]
    # SOURCE.md: peak vertical force 805 N (right) and 811 N (left)
    assert plates[0].force[:, 1].max() == pytest.approx(804.86, abs=0.01)
    assert plates[1].force[:, 1].max() == pytest.approx(810.84, abs=0.01)
    assert plates[0].force[0, 0] == pytest.approx(101.5119767)


def test_jw_csv_mat_and_simm_mot_agree_and_are_si():
    csv = read_motion(J / "csv_ngait_og5" / "IK_ngait_og5.csv")
    mat = read_motion(J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat")
    np.testing.assert_allclose(csv["knee_flexion"], mat["knee_flexion"], atol=1e-9)
    assert csv["knee_ty"][0] == pytest.approx(0.04199999)           # metres stay metres
    assert np.rad2deg(csv["knee_flexion"]).min() == pytest.approx(-67.04, abs=0.1)  # SOURCE.md: about -67 deg
    simm = read_motion(J / "workshop_bcn2024" / "ExperimentalData" / "jw_ngait_og1_new_v4_converted.mot")
    assert simm["hip_flexion"][0] == pytest.approx(np.deg2rad(-17.60957283))
    states = read_motion(J / "workshop_bcn2024" / "ExperimentalData" / "KneeProsthesis_states2track.sto")
    assert states.units["/jointset/knee_joint/knee_tx/value"] == "m"


def test_jw_grf_three_plates_and_implant_loads_in_newton():
    plates = grf_plates(read_grf(J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat"))
    assert [p.name for p in plates] == ["plate1", "plate2", "plate3"]
    kcf = read_implant_loads(J / "csv_ngait_og5" / "KCF_ngait_og5.csv")
    assert kcf["PM"][0] == pytest.approx(6.404563 * LBF_TO_N)
    assert (kcf["PM"] + kcf["AM"]).max() == pytest.approx(1078, abs=1)   # SOURCE.md: peak medial ~1078 N
    idm = read_forces(J / "reducepoly_subject_GC" / "ID" / "ID_ngait_og5.mat")
    assert idm.metadata["inDegrees"] == "no" and idm.units["knee_tx_force"] == "N"


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_new_style_header(tmp_path):
    ok = _write(tmp_path, "new.sto", "DataType=double\nversion=3\ninDegrees=yes\nendheader\n"
                "time\tknee_angle_r\tpelvis_ty\n0\t90\t1\n0.1\t45\t1.1\n")
    m = read_motion(ok)
    assert m["knee_angle_r"].tolist() == pytest.approx([np.pi / 2, np.pi / 4])
    assert m["pelvis_ty"].tolist() == [1.0, 1.1]


@pytest.mark.parametrize("name, text, message", [
    ("bad.mot", "version=1\nnRows=2\nnColumns=3\ninDegrees=no\nendheader\ntime\ta\tb\n0\t1\t2\n0.1\tx1\t2\n",
     r"bad\.mot, line 8, column 2: 'x1' in column 'a'"),
    ("short.mot", "endheader\ntime a b\n0 1 2\n0.1 1\n", r"short\.mot, line 4, column 3: has 2 values"),
    ("nan.csv", "time,a\n0,1\n0.1,nan\n", r"nan\.csv, line 3, column 2: value of 'a' at t = 0.1 is nan"),
    ("rows.mot", "nRows=5\nendheader\ntime a\n0 1\n", "nRows=5 but the file has 1"),
    ("noend.mot", "time a\n0 1\n", "no 'endheader'"),
    ("back.mot", "endheader\ntime a\n0 1\n0.2 1\n0.1 1\n", r"line 5, column 1: time is not strictly increasing"),
])
def test_malformed_motion_file_is_an_error_naming_file_line_and_column(tmp_path, name, text, message):
    with pytest.raises(DataFileError, match=message):
        read_motion(_write(tmp_path, name, text))


def test_malformed_grf_and_missing_files(tmp_path):
    grf = _write(tmp_path, "grf.mot", "endheader\ntime ground_force_vx ground_force_vy\n0 1 2\n")
    with pytest.raises(DataFileError, match="missing column"):
        grf_plates(read_grf(grf))
    with pytest.raises(OcpConstraintsError, match="does not exist"):
        read_motion(tmp_path / "nothing.mot")
    assert issubclass(DataFileError, OcpConstraintsError)
