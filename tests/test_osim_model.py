"""OpenSim model import and forward kinematics, checked independently of the code under test."""
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.biomech.osim_functions import simm_spline
from ocp_constraints.biomech.osim_model import load_osim
from ocp_constraints.errors import OsimModelError

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
GAIT = DATA / "opensim-gait2354-subject01" / "subject01_simbody.osim"
JW = DATA / "grand-challenge-knee-jw" / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"


@pytest.fixture(scope="module")
def gait():
    return load_osim(GAIT)


@pytest.fixture(scope="module")
def jw():
    return load_osim(JW)


def _rot(axis, a):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def _poses(model, values):
    p = {n: values.get(n, model.coordinates[n].default) for n in model.coordinates}
    X = model.poses(p)
    return {b: (np.asarray(ca.DM(R)), np.asarray(ca.DM(x)).ravel()) for b, (R, x) in X.items()}


def test_bodies_masses_and_tree(gait, jw):
    assert sum(b.mass for b in gait.bodies.values()) == pytest.approx(72.6, abs=0.05)   # SOURCE.md
    assert sum(b.mass for b in jw.bodies.values()) == pytest.approx(62.6, abs=0.05)
    assert gait.bodies["tibia_r"].com.tolist() == [0, -0.184557, 0]
    assert len(gait.coordinates) == 23 and gait.coordinates["knee_angle_r"].rotational
    assert not gait.coordinates["pelvis_tx"].rotational
    assert jw.joints["knee"].reversed and not jw.joints["hip"].reversed
    assert jw.coordinates["knee_adduction"].locked and not jw.coordinates["knee_flexion"].locked


def test_simm_spline_interpolates_and_matches_end_cubic():
    x = np.array([-2.0944, -1.74533, -1.39626, -1.0472, -0.698132, -0.349066, -0.174533, 0.197344])
    y = np.array([-0.0032, 0.00179, 0.00411, 0.0041, 0.00212, -0.001, -0.0031, -0.005227])
    s = simm_spline(x, y)
    X = ca.SX.sym("x")
    f = ca.Function("f", [X], [s(X)])
    d3 = ca.Function("d3", [X], [ca.jacobian(ca.jacobian(ca.jacobian(s(X), X), X), X)])
    assert [float(f(v)) for v in x] == pytest.approx(y.tolist(), abs=1e-15)
    # Forsythe-Malcolm-Moler end condition: third derivative = that of the cubic through 4 end points
    c0 = np.polyfit(x[:4], y[:4], 3)[0] * 6
    assert float(d3(x[0] + 1e-6)) == pytest.approx(c0, rel=1e-8)
    # continuity of value and slope across a knot; linear extrapolation outside
    df = ca.Function("df", [X], [ca.jacobian(s(X), X)])
    assert float(df(x[3] - 1e-9)) == pytest.approx(float(df(x[3] + 1e-9)), abs=1e-6)
    assert float(f(x[0] - 0.1)) == pytest.approx(y[0] - 0.1 * float(df(x[0])), abs=1e-12)


def test_gait2354_knee_and_hip_by_hand(gait):
    theta = -0.349066      # a knot of both knee splines: the translations are the tabulated values
    P = _poses(gait, {"knee_angle_r": theta, "hip_flexion_r": 0.3, "pelvis_tilt": 0.1})
    Rf, xf = P["femur_r"]
    Rt, xt = P["tibia_r"]
    np.testing.assert_allclose(Rf.T @ (xt - xf), [1.14724 * -0.001, 1.14724 * -0.3976, 0], atol=1e-12)
    np.testing.assert_allclose(Rf.T @ Rt, _rot([0, 0, 1], theta), atol=1e-12)
    Rp, xp = P["pelvis"]
    np.testing.assert_allclose(xf, xp + Rp @ [-0.0724376, -0.0677245, 0.0855522], atol=1e-12)
    np.testing.assert_allclose(Rp.T @ Rf, _rot([0, 0, 1], 0.3), atol=1e-12)


def test_jw_reversed_knee_by_hand(jw):
    q = {"knee_flexion": -0.6, "knee_adduction": 0.05, "knee_rotation": -0.1, "knee_tx": 0.01,
         "knee_ty": 0.042, "knee_tz": -0.003, "hip_flexion": 0.4}
    P = _poses(jw, q)
    Rt, xt = P["tibial_tray"]
    Rc, xc = P["femoral_component"]
    R = _rot([0, 0, 1], -0.6) @ _rot([1, 0, 0], 0.05) @ _rot([0, -1, 0], -0.1)   # body-fixed Z, X, -Y
    np.testing.assert_allclose(Rt.T @ Rc, R, atol=1e-12)
    np.testing.assert_allclose(Rt.T @ (xc - xt), [0.01, 0.042, -0.003], atol=1e-12)
    # the femoral component is welded to the femur with a fixed offset
    Rfe, xfe = P["femur"]
    np.testing.assert_allclose(Rfe.T @ (xc - xfe), [0, -0.39335, 0], atol=1e-12)


@pytest.mark.parametrize("which", ["gait", "jw"])
def test_ad_velocities_match_finite_differences(which, gait, jw):
    model = gait if which == "gait" else jw
    bodies = ["pelvis", "femur_r", "tibia_r", "calcn_r"] if which == "gait" else ["femur", "tibial_tray", "tibia", "calcaneus"]
    F = model.kinematics_function(bodies)
    n = len(model.coordinates)
    rng = np.random.default_rng(1)
    p0, p1, p2 = 0.3 * rng.standard_normal(n), rng.standard_normal(n), rng.standard_normal(n)

    def at(t):
        return p0 + p1 * t + p2 * t * t, p1 + 2 * p2 * t, 2 * p2

    out = [np.asarray(x) for x in F(*at(0.2))]
    h = 1e-5
    Rp, xp = (np.asarray(F(*at(0.2 + h))[i]) for i in (0, 1))
    Rm, xm = (np.asarray(F(*at(0.2 - h))[i]) for i in (0, 1))
    np.testing.assert_allclose(out[2], (xp - xm) / (2 * h), atol=1e-7)        # vbar
    for k in range(len(bodies)):
        R = out[0][9 * k:9 * k + 9].reshape(3, 3, order="F")
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        Rd = (Rp[9 * k:9 * k + 9] - Rm[9 * k:9 * k + 9]).reshape(3, 3, order="F") / (2 * h)
        W = Rd @ R.T
        np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], out[3][3 * k:3 * k + 3].ravel(), atol=1e-7)
    vp, vm = (np.asarray(F(*at(0.2 + s))[2]) for s in (h, -h))
    np.testing.assert_allclose(out[4], (vp - vm) / (2 * h), atol=1e-5)        # abar
    wp, wm = (np.asarray(F(*at(0.2 + s))[3]) for s in (h, -h))
    np.testing.assert_allclose(out[5], (wp - wm) / (2 * h), atol=1e-5)        # alpha


def test_unsupported_and_broken_models(tmp_path):
    old = tmp_path / "old.osim"
    old.write_text('<?xml version="1.0"?><OpenSimDocument Version="30000"><Model name="m"/></OpenSimDocument>')
    with pytest.raises(OsimModelError, match="older than OpenSim 4.0"):
        load_osim(old)
    text = GAIT.read_text().replace('<CustomJoint name="knee_r">', '<BallJoint name="knee_r">', 1)
    text = text.replace("</CustomJoint>\n\t\t\t\t<CustomJoint name=\"ankle_r\">", "</BallJoint>\n\t\t\t\t<CustomJoint name=\"ankle_r\">", 1)
    bad = tmp_path / "ball.osim"
    bad.write_text(text)
    with pytest.raises(OsimModelError, match="joint 'knee_r' \\(BallJoint\\): joint type not supported"):
        load_osim(bad)
