"""The quadriceps' pull on the tibia through one patellar ligament (issue 15, C13)."""
import numpy as np
import pytest

from ocp_constraints.biomech.knee_muscles import PRIMARY, SECONDARY
from ocp_constraints.biomech.knee_quadriceps import patellar_ligament_arms
from ocp_constraints.errors import KneeError

ROWS = PRIMARY + SECONDARY
MUSCLES = ["bfsh", "recfem", "vasint", "vaslat", "vasmed"]


def test_the_side_vasti_take_the_central_ligament_lines_locked_rows_and_nothing_else_changes():
    rng = np.random.default_rng(3)
    R = rng.normal(size=(4, len(ROWS), len(MUSCLES)))
    out = patellar_ligament_arms(R, MUSCLES, ROWS)
    locked = [ROWS.index(c) for c in SECONDARY]
    central = 0.5 * (R[:, :, 1] + R[:, :, 2])              # rectus femoris and vastus intermedius, by hand
    for m in ("vaslat", "vasmed"):
        j = MUSCLES.index(m)
        np.testing.assert_array_equal(out[:, locked, j], central[:, locked])
        free = [i for i in range(len(ROWS)) if i not in locked]      # knee flexion and the other primaries: the model's
        np.testing.assert_array_equal(out[:, free, j], R[:, free, j])
    for m in ("bfsh", "recfem", "vasint"):
        np.testing.assert_array_equal(out[:, :, MUSCLES.index(m)], R[:, :, MUSCLES.index(m)])
    assert not np.shares_memory(out, R)


def test_a_model_without_the_jw_quadriceps_is_refused_naming_them():
    with pytest.raises(KneeError, match=r"no \['vasint'\].*--quadriceps model-paths"):
        patellar_ligament_arms(np.zeros((1, len(ROWS), 3)), ["recfem", "vaslat", "vasmed"], ROWS)


def test_an_unknown_quadriceps_line_is_refused_before_any_file_is_read():
    from ocp_constraints.biomech.knee_pipeline import run_knee

    with pytest.raises(KneeError, match="unknown quadriceps line 'tendon' .*model-paths, patellar-ligament"):
        run_knee("no_model.osim", "ik", "grf", quadriceps="tendon")
