"""The passive hip moment of the knee pipeline (issue 15): the published formula, its signs, and the
hip flexion balance it changes."""
import math
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.biomech.knee_passive import passive_hip_moment
from ocp_constraints.errors import KneeError

J = Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw"
JW_MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"


def test_riener_edrich_hip_moment_values_and_signs():
    # Riener & Edrich 1999, hip: exp(1.4655 - 0.0034 K - 0.0750 H) - exp(1.3403 - 0.0226 K + 0.0305 H) + 8.072
    assert passive_hip_moment(0.0, 0.0) == pytest.approx(math.exp(1.4655) - math.exp(1.3403) + 8.072, abs=1e-12)
    assert passive_hip_moment(0.0, 0.0) == pytest.approx(8.5815, abs=1e-4)
    # hip extended 20 degrees, knee flexed 30 degrees (the JW knee_flexion is negative in flexion)
    h, k = math.radians(-20.0), math.radians(-30.0)
    expected = math.exp(1.4655 - 0.0034 * 30 + 0.0750 * 20) - math.exp(1.3403 - 0.0226 * 30 - 0.0305 * 20) + 8.072
    assert passive_hip_moment(h, k) == pytest.approx(expected, rel=1e-12)
    # extension stretches the anterior structures: the flexion moment grows monotonically as the hip extends
    hips = np.radians(np.linspace(30, -30, 61))
    m = passive_hip_moment(hips, np.zeros_like(hips))
    assert np.all(np.diff(m) > 0) and m[-1] > 40.0


def test_the_muscles_carry_the_net_hip_moment_less_the_passive_one():
    from ocp_constraints.biomech.gait import run_inverse_dynamics
    from ocp_constraints.biomech.knee_model import contact_matrix_function
    from ocp_constraints.biomech.knee_muscles import MusclePaths, muscle_parameters
    from ocp_constraints.biomech.knee_static import RESERVED, frame_data, solve_static

    g = run_inverse_dynamics(JW_MODEL, J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat",
                             J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat",
                             times=np.linspace(2.70, 2.80, 5))                      # terminal stance
    paths = MusclePaths()
    Qc, R, A = frame_data(g, paths, contact_matrix_function())
    names, P = g.coordinate_names, g.states["p"]
    Mp = passive_hip_moment(P[:, names.index("hip_flexion")], P[:, names.index("knee_flexion")])
    assert np.all(P[:, names.index("hip_flexion")] < 0) and np.all(Mp > 10.0)      # hip extended: passive flexion
    Qp = Qc.copy()
    Qp[:, 0] -= Mp
    F0 = np.array([muscle_parameters(JW_MODEL, paths.muscles)[m].max_isometric_force for m in paths.muscles])
    r = solve_static(g.t, Qp, R, A, F0)
    hip = RESERVED.index("hip_flexion")
    muscles = np.einsum("nm,nm->n", R[:, hip, :], r.force) + r.reserve[:, hip]
    np.testing.assert_allclose(muscles + Mp, g.generalized_force("hip_flexion"), atol=1e-6)


def test_an_unknown_passive_model_is_refused():
    from ocp_constraints.biomech.knee_pipeline import run_knee

    with pytest.raises(KneeError, match="unknown passive hip model 'stiff' .*riener-edrich-1999, riener-edrich-1999-hip-knee-ankle, none"):
        run_knee(JW_MODEL, "ik", "grf", passive_hip="stiff")


def test_comparison_reports_r2_and_rmse_in_body_weights():
    from ocp_constraints.biomech.knee_pipeline import compare

    t = np.linspace(0.0, 1.0, 5)
    measured = (t, np.array([0.0, 100.0, 200.0, 100.0, 0.0]), np.full(5, 50.0))
    out = compare(t, {"medial": measured[1] + 10.0}, measured, bw=500.0)["medial"]
    # SSE = 5 * 10^2 = 500; SST = sum((m - 80)^2) = 6400 + 400 + 14400 + 400 + 6400 = 28000
    assert out["r2"] == pytest.approx(1 - 500 / 28000, rel=1e-12)
    assert out["rmse_bw"] == pytest.approx(10.0 / 500.0, rel=1e-12) and out["peak_error_bw"] == pytest.approx(0.02)


def test_comparison_uses_only_the_frames_the_measured_record_covers():
    from ocp_constraints.biomech.knee_pipeline import compare

    t = np.linspace(0.0, 1.0, 11)                    # frames every 0.1 s
    tm = np.linspace(0.5, 2.0, 16)                   # the record starts half-way through the cycle
    measured = (tm, np.full(16, 100.0), np.zeros(16))
    y = np.where(t < 0.45, 1e6, 110.0)              # wild values before the record starts must not count
    out = compare(t, {"medial": y}, measured, bw=100.0)["medial"]
    assert out["frames_compared"] == 6 and out["rmse_bw"] == pytest.approx(0.1, rel=1e-12)
    assert np.isnan(out["r2"]) and np.isnan(out["r"])          # a constant measured curve: undefined, not -inf
    with pytest.raises(KneeError, match=r"measured loads cover 5 \.\.\. 6 s, which is not the gait cycle 0 \.\.\. 1 s"):
        compare(t, {"medial": y}, (np.array([5.0, 6.0]), np.ones(2), np.ones(2)), bw=100.0)


def test_riener_edrich_knee_and_ankle_moments_values_and_signs():
    from ocp_constraints.biomech.knee_passive import (HIP_KNEE_ANKLE, passive_ankle_moment,
                                                      passive_generalized_forces, passive_knee_moment)

    # the paper's knee and ankle equations at hip 10 deg flexion, knee 30 deg flexion, ankle 10 deg dorsiflexion
    # (the paper's A is plantarflexion: A = -10; the JW knee_flexion is -30 deg, ankle_angle +10 deg)
    H, K, A = 10.0, 30.0, -10.0
    knee = (math.exp(1.800 - 0.0460 * A - 0.0352 * K + 0.0217 * H) - math.exp(-3.971 - 0.0004 * A + 0.0495 * K - 0.0128 * H)
            - 4.820 + math.exp(2.220 - 0.150 * K))
    ankle = math.exp(2.1016 - 0.0843 * A - 0.0176 * K) - math.exp(-7.9763 + 0.1949 * A + 0.0008 * K) - 1.792
    h, k, a = math.radians(10.0), math.radians(-30.0), math.radians(10.0)
    assert passive_knee_moment(h, k, a) == pytest.approx(knee, rel=1e-12)
    assert passive_ankle_moment(k, a) == pytest.approx(ankle, rel=1e-12)
    # physiology: dorsiflexion is resisted (plantarflexion moment), more with the knee straight (gastrocnemii);
    # a straight knee is pushed into flexion, a deeply flexed one into extension
    assert passive_ankle_moment(0.0, math.radians(20.0)) > passive_ankle_moment(math.radians(-60.0), math.radians(20.0)) > 5
    assert passive_knee_moment(0.0, 0.0, 0.0) > 5 and passive_knee_moment(0.0, math.radians(-80.0), 0.0) < -4
    # generalized forces on the JW coordinates: flexion and plantarflexion are negative there
    names = ["hip_flexion", "knee_flexion", "ankle_angle"]
    Q = passive_generalized_forces(HIP_KNEE_ANKLE, names, np.array([[h, k, a]]))
    assert Q["hip_flexion"][0] == pytest.approx(float(passive_hip_moment(h, k)), rel=1e-12)
    assert Q["knee_flexion"][0] == pytest.approx(-knee, rel=1e-12)
    assert Q["ankle_angle"][0] == pytest.approx(-ankle, rel=1e-12)
    assert set(passive_generalized_forces("riener-edrich-1999", names, np.array([[h, k, a]]))) == {"hip_flexion"}


def _riener_edrich_generalized_forces(H, K, A):
    """The published hip, knee and ankle equations (degrees: hip flexion H, knee flexion K, ankle plantarflexion A
    positive) as generalized forces on the JW hip_flexion, knee_flexion (negative in flexion) and ankle_angle
    (positive in dorsiflexion) coordinates, written out here independently of ocp_constraints.biomech.knee_passive."""
    hip = np.exp(1.4655 - 0.0034 * K - 0.0750 * H) - np.exp(1.3403 - 0.0226 * K + 0.0305 * H) + 8.072
    knee = (np.exp(1.800 - 0.0460 * A - 0.0352 * K + 0.0217 * H) - np.exp(-3.971 - 0.0004 * A + 0.0495 * K - 0.0128 * H)
            - 4.820 + np.exp(2.220 - 0.150 * K))
    ankle = np.exp(2.1016 - 0.0843 * A - 0.0176 * K) - np.exp(-7.9763 + 0.1949 * A + 0.0008 * K) - 1.792
    return {"hip_flexion": hip, "knee_flexion": -knee, "ankle_angle": -ankle}


def test_hill_fibres_passive_tension_is_counted_once_within_the_published_passive_moments():
    """Riener & Edrich measured all passive structures, muscles' passive tension included: with Hill muscles the
    fibres' passive force plus the joint-level passive torque must equal the published moment on hip flexion,
    knee flexion and ankle, not the published moment plus the fibres' share (the double count this checks)."""
    from ocp_constraints.biomech.knee_model import contact_matrix_function
    from ocp_constraints.biomech.knee_muscles import MusclePaths
    from ocp_constraints.biomech.knee_pipeline import run_knee
    from ocp_constraints.biomech.knee_static import RESERVED, frame_data

    D = J / "reducepoly_subject_GC"
    run = run_knee(JW_MODEL, D / "IK" / "IK_ngait_og5.mat", D / "GRF" / "GRF_ngait_og5.mat", muscle_model="hill", method="static")
    g, r = run["gait"], run["result"]
    Qc, R, A = frame_data(g, MusclePaths(), contact_matrix_function())
    names, P = g.coordinate_names, np.degrees(g.states["p"])
    published = _riener_edrich_generalized_forces(P[:, names.index("hip_flexion")], -P[:, names.index("knee_flexion")],
                                                  -P[:, names.index("ankle_angle")])
    fibres = np.einsum("ncm,nm->nc", R, run["hill"].passive)
    tension = np.einsum("ncm,nm->nc", R, r.force)          # every muscle's whole tension, active + fibres' passive
    contact = np.einsum("njc,nj->nc", A, r.lam)
    for c, m in published.items():
        i = RESERVED.index(c)
        assert np.abs(fibres[:, i]).max() > 1.0, c          # the fibres do carry part of it: the check is not empty
        np.testing.assert_allclose(run["passive_moments"][c] + fibres[:, i], m, rtol=1e-9, atol=1e-9)
        # the balance the optimiser met: muscles (fibres included) + contact + reserve + joint-level passive = Q
        np.testing.assert_allclose(tension[:, i] + contact[:, i] + r.reserve[:, i] + run["passive_moments"][c],
                                   Qc[:, i], atol=1e-4)
