"""``ocp-constraints knee --param``: condyle centres that replace the implant geometry's.

The contact matrix ``A`` (``Phi_p = lambda A``, eq. 39) with moved centres is checked against
the generalized forces of a unit normal force written out by hand; bad parameters are refused
before any file is read.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ocp_constraints.biomech.knee_model import default_parameters, contact_matrix_function
from ocp_constraints.biomech.knee_pipeline import condyle_overrides, run_knee
from ocp_constraints.cli.main import main
from ocp_constraints.errors import KneeError


def test_moved_condyle_centres_give_the_hand_generalized_forces():
    # A unit force along the tray's Y axis (the plateau normal) on the line through the condyle
    # centre c = (cx, cy, cz) (femoral frame). The femur's placement in the tray frame is
    # p_FM + Rz(f) Rx(a) R_{-y}(r) c; at a = r = 0 its generalized force on coordinate k is
    # Y . d(R c)/dk: flexion  Y . (e_z x Rz c) = cx cos f - cy sin f,
    # adduction Y . Rz (e_x x c) = -cz cos f, rotation Y . Rz (-e_y x c) = -cz sin f, knee_ty 1.
    over = condyle_overrides({"medial_cx": "0.004", "medial_cy": "-0.002", "medial_cz": "0.03",
                              "lateral_cx": "-0.001", "lateral_cy": "0.001", "lateral_cz": "-0.02"})
    p = {**default_parameters(), **over}
    f = 0.3
    A = np.asarray(contact_matrix_function(p)(np.array([f, 0.0, 0.0, 0.0, 0.042, 0.0])))
    for row, side in enumerate(("medial", "lateral")):
        cx, cy, cz = (p[f"{side}_c{k}"] for k in "xyz")
        expected = [cx * math.cos(f) - cy * math.sin(f), -cz * math.cos(f), -cz * math.sin(f), 0.0, 1.0, 0.0]
        np.testing.assert_allclose(A[row], expected, atol=1e-12)


@pytest.mark.parametrize("params, message", [
    ({"medial_radius": "0.03"}, "'medial_radius' is not one the contact loads depend on"),
    ({"spacing": "0.04"}, "'spacing' is not one"),
    ({"lateral_cz": "nan"}, "'lateral_cz' = 'nan' is not a finite number"),
    ({"lateral_cz": "abc"}, "'lateral_cz' = 'abc' is not a finite number"),
])
def test_bad_parameters_are_refused_before_any_file_is_read(params, message):
    with pytest.raises(KneeError, match=message):
        run_knee("no_model.osim", "no_motion.csv", "no_grf.csv", parameters=params)


def test_cli_bad_param_exits_2_naming_it(tmp_path, capsys):
    code = main(["knee", "--model", "m.osim", "--motion", "ik.csv", "--grf", "grf.csv", "--out", str(tmp_path / "k"),
                 "--param", "medial_height=0.01"])
    assert code == 2
    assert "'medial_height' is not one the contact loads depend on" in capsys.readouterr().err
