"""The tilted pendulum's hinge loads (paper sec. 3.1, eq. 15) against M_A = dH_A/dt by hand."""
from __future__ import annotations

import math

import numpy as np

from ocp_constraints import build_scene
from ocp_constraints.scenes.tasks import simulate_scene


def test_hinge_force_and_both_constraint_moments_match_the_balance_about_the_hinge():
    scene = build_scene("pendulum")
    traj = simulate_scene(scene, 3.0)
    p = scene.model.parameters
    m, L, g = p["mass"], p["length"], p["gravity"]
    tilt = math.radians(p["tilt_deg"])
    d = np.array([0.0, -math.cos(tilt), math.sin(tilt)])
    J_com = m * L**2 / 12 * (np.eye(3) - np.outer(d, d))
    E3, weight = np.array([0, 0, 1.0]), np.array([0, -m * g, 0])
    loads = traj.loads()
    for k in range(0, len(traj), 7):
        psi, w = traj.sample("rod.psi")[k], traj.sample("rod.psi_dot")[k]
        Q = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]])
        r = Q @ (L / 2 * d)  # hinge -> center of mass
        J_A = Q @ J_com @ Q.T + m * (r @ r * np.eye(3) - np.outer(r, r))
        gravity_moment = np.cross(r, weight)
        alpha = gravity_moment[2] / J_A[2, 2]  # E3 component: no constraint moment about the axis
        dH = J_A @ E3 * alpha + w**2 * np.cross(E3, J_A @ E3)
        M_c = dH - gravity_moment  # the hinge moment about A (its force passes through A)
        a_com = alpha * np.cross(E3, r) + w**2 * np.cross(E3, np.cross(E3, r))
        F_c = m * a_com - weight
        lam = traj.lam[k]
        assert np.allclose(lam[:3], F_c, rtol=0, atol=1e-9 * m * g)
        assert np.allclose(lam[3:], M_c[:2], rtol=0, atol=1e-9 * m * g * L)
        assert np.allclose([loads[f"hinge.M_{a}"][k] for a in "xyz"], [lam[3], lam[4], 0.0], atol=1e-12)
        assert np.allclose([loads[f"hinge.point_{a}"][k] for a in "xyz"], 0.0, atol=1e-9)


def test_simulate_scene_takes_a_scene_name_as_well_as_a_scene():
    by_name = simulate_scene("pendulum", 0.2)
    built = simulate_scene(build_scene("pendulum"), 0.2)
    assert by_name.t[-1] == 0.2
    np.testing.assert_array_equal(by_name.sample("rod.psi"), built.sample("rod.psi"))
