"""Pointwise inverse dynamics against closed forms."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ocp_constraints import Model, SystemEquations, build_scene, joints
from ocp_constraints.errors import ModelError
from ocp_constraints.dynamics.inverse import InverseDynamics


def test_sliding_cylinder_multipliers_match_eq_18_for_a_prescribed_motion():
    # The cylinder's free motion in closed form: uniform translation and spins
    # (theta = pi/2, z = 0). Eq. (18): F_c = m g E3, M_c = I_a psi' phi' (cos phi e1 - sin phi e2),
    # and M_c = lambda_2 (e3 x E3) = -lambda_2 (cos phi e1 - sin phi e2), so lambda_2 = -I_a psi' phi'.
    scene = build_scene("sliding_cylinder")
    eqs = SystemEquations(scene.model)
    p = scene.model.parameters
    m, Ia = p["mass"], p["mass"] * p["radius"] ** 2 / 2
    t = np.linspace(0, 2, 21)
    xd, yd, psid, phid = 0.4, -0.25, 1.2, 5.0
    q = np.column_stack([0.1 + xd * t, -0.2 + yd * t, 0 * t, 0.3 + psid * t, np.full_like(t, math.pi / 2), 0.5 + phid * t])
    qdot = np.tile([xd, yd, 0, psid, 0, phid], (len(t), 1))
    result = InverseDynamics(eqs).solve_coordinates(t, q, qdot, np.zeros_like(q))
    assert np.allclose(result.multiplier("plane.normal"), m * p["gravity"], rtol=1e-12)
    assert np.allclose(result.multiplier("plane.tilt"), -Ia * psid * phid, rtol=1e-12)
    assert result.residual.max() < 1e-12


def _actuated_rod():
    """Planar rod hinged at its end, a motor torque about E3 (N m) as the input."""
    model = Model("rod", gravity=(0, -9.81, 0))
    rod = model.add_body("rod", 2.0, np.diag([0.2, 1e-3, 0.2]), rotation="321")
    A = rod.point("A", [0, 0.5, 0])
    joints.revolute(model, "hinge", A)
    tau = model.add_input("motor")
    model.add_torque("motor", rod, ca.vertcat(0, 0, tau))
    return model


def test_motor_torque_holding_a_rod_still_is_m_g_l_sin_angle():
    model = _actuated_rod()
    eqs = SystemEquations(model)
    angles = np.linspace(-1.2, 1.2, 7)
    q = np.array([[0.5 * math.sin(a), -0.5 * math.cos(a), 0, a, 0, 0] for a in angles])
    zeros = np.zeros((len(angles), 6))
    result = InverseDynamics(eqs).solve(angles * 0, q, zeros, zeros)
    assert np.allclose(result.input("motor"), 2.0 * 9.81 * 0.5 * np.sin(angles), rtol=1e-12, atol=1e-12)
    # The hinge then carries the weight: F_c = m g E2, no moments.
    assert np.allclose(result.multiplier("hinge.v2"), 2.0 * 9.81, rtol=1e-12)
    assert np.allclose(result.lam[:, [0, 2, 3, 4]], 0, atol=1e-12)


def test_rotating_rod_needs_centripetal_hinge_force_and_inertial_torque():
    model = _actuated_rod()
    eqs = SystemEquations(model)
    # a = 0.3 + 2 t + 0.5 t^2: angular speed w = 2 + t, angular acceleration 1.
    t = np.linspace(0, 1, 5)
    a, w = 0.3 + 2 * t + 0.5 * t**2, 2 + t
    r = 0.5
    q = np.column_stack([r * np.sin(a), -r * np.cos(a), 0 * t, a, 0 * t, 0 * t])
    qd = np.column_stack([r * w * np.cos(a), r * w * np.sin(a), 0 * t, w, 0 * t, 0 * t])
    qdd = np.column_stack([r * (np.cos(a) - w**2 * np.sin(a)), r * (np.sin(a) + w**2 * np.cos(a)), 0 * t, 1 + 0 * t, 0 * t, 0 * t])
    res = InverseDynamics(eqs).solve_coordinates(t, q, qd, qdd)
    I_hinge = 0.2 + 2.0 * r**2
    assert np.allclose(res.input("motor"), I_hinge * 1.0 + 2.0 * 9.81 * r * np.sin(a), rtol=1e-12)
    # Hinge force = m (acceleration of the center of mass) - m g.
    assert np.allclose(res.multiplier("hinge.v1"), 2.0 * qdd[:, 0], rtol=1e-12, atol=1e-12)
    assert np.allclose(res.multiplier("hinge.v2"), 2.0 * qdd[:, 1] + 2.0 * 9.81, rtol=1e-12)


def test_a_motion_the_model_cannot_make_leaves_a_reported_residual():
    # Without the motor, the rod's angular acceleration is fixed by gravity:
    # alpha = -m g r sin(a) / I_hinge. Asking for another one is over-determined.
    model = Model("rod", gravity=(0, -9.81, 0))
    rod = model.add_body("rod", 2.0, np.diag([0.2, 1e-3, 0.2]), rotation="321")
    joints.revolute(model, "hinge", rod.point("A", [0, 0.5, 0]))
    eqs = SystemEquations(model)
    r, a = 0.5, 0.7
    I_hinge = 0.2 + 2.0 * r**2
    q = np.array([[r * math.sin(a), -r * math.cos(a), 0, a, 0, 0]])
    solver = InverseDynamics(eqs)

    def accelerations(alpha):
        return np.array([[r * alpha * math.cos(a), r * alpha * math.sin(a), 0, 0, 0, alpha]])

    alpha = -2.0 * 9.81 * r * math.sin(a) / I_hinge
    assert solver.solve(0.0, q, np.zeros((1, 6)), accelerations(alpha)).residual[0] < 1e-12
    assert solver.solve(0.0, q, np.zeros((1, 6)), accelerations(alpha + 1.0)).residual[0] > 0.1


def test_non_finite_samples_are_named():
    eqs = SystemEquations(_actuated_rod())
    q = np.zeros((2, 6))
    q[1, 3] = np.nan
    with pytest.raises(ModelError, match=r"q is not finite at sample 1"):
        InverseDynamics(eqs).solve([0, 1], q, np.zeros((2, 6)), np.zeros((2, 6)))


def test_external_loads_enter_as_applied_loads():
    """A measured force F at the rod's tip, held still: motor = m g r sin(a) - (r_tip x F)_z, hinge takes the rest."""
    model = _actuated_rod()
    eqs = SystemEquations(model)
    angles = np.array([-0.4, 0.3, 1.0])
    r, F = 0.5, np.array([3.0, -5.0, 0.0])
    q = np.array([[r * math.sin(a), -r * math.cos(a), 0, a, 0, 0] for a in angles])
    ext = np.zeros((3, 6))
    ext[:, :3] = F
    tip_from_com = np.array([[r * math.sin(a), -r * math.cos(a), 0] for a in angles])   # tip at 2 r from the hinge
    ext[:, 3:] = np.cross(tip_from_com, F)                                                 # moment about the com
    zeros = np.zeros((3, 6))
    res = InverseDynamics(eqs).solve(angles * 0, q, zeros, zeros, external=ext)
    tip = 2 * tip_from_com
    assert np.allclose(res.input("motor"), 2.0 * 9.81 * r * np.sin(angles) - np.cross(tip, F)[:, 2], rtol=1e-12, atol=1e-12)
    assert np.allclose(res.multiplier("hinge.v1"), -F[0], atol=1e-12)
    assert np.allclose(res.multiplier("hinge.v2"), 2.0 * 9.81 - F[1], atol=1e-12)
    assert res.residual.max() < 1e-12
    with pytest.raises(ModelError, match=r"external must have shape \(3, 6\)"):
        InverseDynamics(eqs).solve(angles * 0, q, zeros, zeros, external=ext[:, :3])



def test_balances_singular_at_a_later_sample_are_named():
    """The block solve divides by zero where a constraint's gradient vanishes: the sample is named.

    Six hand-written constraints hold a body still; the first one's gradient is ``x`` (its
    position), so the balances are regular at x = 1 (the first sample, which the rank check
    sees) and singular at x = 0 (the third sample)."""
    model = Model("held", gravity=(0, -9.81, 0))
    b = model.add_body("block", 1.0, np.eye(3) * 0.1, rotation="321")
    model.add_constraint("x_scaled", b.xbar[0] * b.vbar[0])
    for k, name in ((1, "vy"), (2, "vz")):
        model.add_constraint(name, b.vbar[k])
    for k, name in enumerate(("wx", "wy", "wz")):
        model.add_constraint(name, b.omega[k])
    inverse = InverseDynamics(SystemEquations(model))
    assert inverse.solution is not None
    x = np.array([1.0, 0.5, 0.0, -0.5])
    q = np.column_stack([x, np.zeros((4, 5))])
    zeros = np.zeros((4, 6))
    with pytest.raises(ModelError, match=r"singular at sample 2 \(t = 0\.2\)"):
        inverse.solve(np.array([0.0, 0.1, 0.2, 0.3]), q, zeros, zeros)
    ok = inverse.solve(np.array([0.0, 0.1]), q[:2], zeros[:2], zeros[:2])
    np.testing.assert_allclose(ok.multiplier("vy"), 9.81, rtol=1e-12)      # the weight, held by vbar_y = 0
