"""The hip moments' uncertainty from the hip joint centre's error, sigma_c = s |e_c x F| (issue 15, C19).

Closed forms (a force along an axis, across it, at an angle), a Monte Carlo estimate of the moment transfer's spread
(a second derivation), the per-frame weights' limits, and on ngait_og5 the hip force and axes against the right leg's
Newton-Euler balance computed here from masses, inertias, kinematics and the ground reaction (no multiplier).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.biomech.knee_id_uncertainty import (CHI3_95, CHI3_MEAN, S_BELL_1989, hjc_moment_sigma,
                                                         hip_force_and_axes, reserve_weights_per_frame)
from ocp_constraints.biomech.knee_static import RESERVE_WEIGHT, RESERVED
from ocp_constraints.errors import KneeError

J = Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw"
JW_MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
IK = J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat"
GRF = J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat"


def test_force_along_an_axis_gives_no_moment_error_about_it_and_across_it_s_times_force():
    F = np.array([[0.0, 700.0, 0.0]])
    axes = np.array([[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]])
    sig = hjc_moment_sigma(F, axes, 0.01)
    assert sig[0, 0] == 0.0
    assert sig[0, 1:] == pytest.approx([7.0, 7.0], rel=1e-12)


def test_force_at_an_angle_gives_s_force_sine():
    th = np.deg2rad(20.0)
    F = 500.0 * np.array([[np.sin(th), np.cos(th), 0.0]])
    sig = hjc_moment_sigma(F, np.array([[[0.0, 1.0, 0.0]]]), 0.0093)
    assert sig[0, 0] == pytest.approx(0.0093 * 500.0 * np.sin(th), rel=1e-12)


def test_sigma_is_the_spread_of_the_moment_about_a_randomly_displaced_centre():
    """Second derivation: the moment of F (applied at P) about O + dr, dr ~ N(0, s^2 I), projected on e, sampled."""
    rng = np.random.default_rng(3)
    s, F, e, P = 0.012, np.array([120.0, -640.0, 85.0]), np.array([0.3, 0.9, -0.2]), np.array([0.1, 0.8, 0.05])
    e = e / np.linalg.norm(e)
    dr = rng.normal(0.0, s, (200_000, 3))
    moments = np.cross(P - dr, F) @ e              # about the displaced centre O + dr, O = 0
    assert moments.std() == pytest.approx(hjc_moment_sigma(F[None], e[None, None], s)[0, 0], rel=0.01)


def test_chi3_conversions():
    rng = np.random.default_rng(4)
    d = np.linalg.norm(rng.normal(0.0, 1.0, (400_000, 3)), axis=1)
    assert np.quantile(d, 0.95) == pytest.approx(CHI3_95, rel=0.01)
    assert d.mean() == pytest.approx(CHI3_MEAN, rel=0.01)
    assert S_BELL_1989 == pytest.approx(0.0093, abs=5e-5)


def test_zero_sigma_gives_todays_uniform_weight_and_large_sigma_a_cheap_reserve():
    w = reserve_weights_per_frame({"hip_rotation": np.zeros(4), "hip_flexion": np.array([0.0, 1.0, 3.0, 5.0])})
    assert w.shape == (4, len(RESERVED))
    assert np.all(w[:, RESERVED.index("hip_rotation")] == RESERVE_WEIGHT)
    assert w[:, RESERVED.index("hip_flexion")] == pytest.approx(1.0 / (2.0 * (np.array([0, 1, 9, 25]) + 0.5)))
    assert np.all(w[:, RESERVED.index("knee_flexion")] == RESERVE_WEIGHT)


@pytest.mark.parametrize("sigma, word", [({"knee_tx": np.ones(2)}, "knee_tx"),
                                         ({"hip_rotation": np.array([1.0, -1.0])}, "hip_rotation"),
                                         ({}, "no row")])
def test_bad_sigma_is_refused_naming_the_row(sigma, word):
    with pytest.raises(KneeError, match=word):
        reserve_weights_per_frame(sigma)


def test_negative_s_is_refused():
    with pytest.raises(KneeError, match="hip joint centre"):
        hjc_moment_sigma(np.ones((1, 3)), np.ones((1, 1, 3)), -0.01)


@pytest.mark.skipif(not IK.exists(), reason="JW trial data not present")
def test_hip_force_and_axes_agree_with_the_legs_newton_euler_balance():
    from ocp_constraints.biomech.gait import run_inverse_dynamics
    from ocp_constraints.mechanics.fast_eval import evaluate

    gait = run_inverse_dynamics(JW_MODEL, IK, GRF, times=2.3 + np.arange(8) / 60.0)
    F, E = hip_force_and_axes(gait)
    osim, bodies, N = gait.osim, list(gait.functions.meta["bodies"]), len(gait.t)
    P, Pd, Pdd = gait.states["p"], gait.states["pdot"], gait.states["pddot"]
    R, xb, _, om, ab, al, _ = evaluate(osim.kinematics_function(bodies).map(N), P.T, Pd.T, Pdd.T)
    nb = len(bodies)
    R = R.T.reshape(N, nb, 3, 3).transpose(0, 1, 3, 2)
    xb, om, ab, al = (a.T.reshape(N, nb, 3) for a in (xb, om, ab, al))
    fext = gait.states["fext"].reshape(N, nb, 6)          # ground reaction per body: force, moment about the COM
    centre = np.column_stack([gait.loads()[f"hip@femur.point_{a}"] for a in "xyz"])
    F_leg, M_leg = np.zeros((N, 3)), np.zeros((N, 3))
    for b in ("femur", "femoral_component", "tibial_tray", "tibia", "patella", "talus", "calcaneus", "toes"):
        k, body = bodies.index(b), osim.bodies[b]
        I = R[:, k] @ np.asarray(body.inertia) @ R[:, k].transpose(0, 2, 1)
        f = body.mass * (ab[:, k] - np.asarray(osim.gravity)) - fext[:, k, :3]
        F_leg += f
        M_leg += (np.einsum("nij,nj->ni", I, al[:, k]) + np.cross(om[:, k], np.einsum("nij,nj->ni", I, om[:, k]))
                  + np.cross(xb[:, k] - centre, f) - fext[:, k, 3:])
    assert np.linalg.norm(F, axis=1).min() > 100.0                # stance: a real check of the sign
    assert np.allclose(F, F_leg, atol=1e-6)                     # the force ON the femur BY the pelvis, ground frame
    assert np.allclose(np.linalg.norm(E, axis=2), 1.0)
    for i, c in enumerate(("hip_flexion", "hip_adduction", "hip_rotation")):
        assert np.allclose(np.einsum("ni,ni->n", E[:, i], M_leg), gait.generalized_force(c), atol=1e-6)
