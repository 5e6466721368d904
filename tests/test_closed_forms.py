"""Closed forms of the paper along simulated motions: sliding disk eq. (4), sliding cylinder eq. (18).

The library's multiplier and loads are compared with the paper's formulas evaluated
from the simulated state and accelerations through *independent* kinematics: a
hand-written 3-1-3 rotation tensor and the dual Euler basis of eq. (11) (see
``conftest.py``), never the library's own Euler basis.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.scenes.registry import build_scene
from ocp_constraints.dynamics.simulate import simulate
from ocp_constraints.mechanics.state import consistent_state


def _independent_rate_functions(indep_kinematics) -> ca.Function:
    """``(q, u, udot) -> (angle rates, angle accelerations, e1, e2, e3)`` for one 3-1-3 body.

    Angle rates ``a_i' = g^i . omega`` (eq. 12 with eq. 11); their time derivatives
    ``a_i'' = g^i . omega' + (d g^i/dt) . omega`` with ``d g^i/dt`` by ``jtimes``
    through the kinematics ``xbar' = vbar``, ``angles' = (g^i . omega)``.
    """
    q, u, udot = ca.SX.sym("q", 6), ca.SX.sym("u", 6), ca.SX.sym("udot", 6)
    angles, omega, omega_dot = q[3:6], u[3:6], udot[3:6]
    dual = indep_kinematics.dual_basis_313_eq11(angles)
    rates = ca.vertcat(*[ca.dot(g, omega) for g in dual])
    qdot = ca.vertcat(u[0:3], rates)
    accel = ca.vertcat(*[ca.dot(g, omega_dot) + ca.dot(ca.jtimes(g, q, qdot), omega) for g in dual])
    Q = indep_kinematics.rotation_of_sequence("313", angles)
    return ca.Function("indep_rates", [q, u, udot], [rates, accel, Q[:, 0], Q[:, 1], Q[:, 2]])


def test_sliding_disk_normal_force_matches_paper_eq4_over_10s(physics_sliding_disk_10s, indep_kinematics):
    """``lambda = m R (theta'' cos(theta) - theta'^2 sin(theta)) + m g`` (eq. 4) at every sample.

    Eq. (4) is ``d/dt(m R theta' cos(theta)) + m g = lambda``: the vertical balance
    ``m z'' = lambda - m g`` with ``z = R sin(theta)``. The derivation agrees with the
    printed formula.
    """
    scene, eqs, traj = physics_sliding_disk_10s
    p = scene.model.parameters
    m, R, g = p["mass"], p["radius"], p["gravity"]
    assert traj.t[-1] == pytest.approx(10.0)
    f = _independent_rate_functions(indep_kinematics)
    lam = traj.sample("contact.n.lambda")
    errors = []
    for k in range(len(traj)):
        rates, accel, *_ = (np.asarray(x).ravel() for x in f(traj.q[k], traj.u[k], traj.udot[k]))
        theta = traj.q[k, 4]
        expected = m * R * (accel[1] * np.cos(theta) - rates[1] ** 2 * np.sin(theta)) + m * g
        errors.append(abs(lam[k] - expected) / (m * g))
    assert max(errors) <= 1e-8
    # The force is the normal force lambda E3 at X_P, without a moment (Table 1).
    loads = traj.loads()
    assert np.abs(loads["contact.F_z"] - lam).max() <= 1e-12 * m * g
    for c in ("contact.F_x", "contact.F_y", "contact.M_x", "contact.M_y", "contact.M_z"):
        assert np.abs(loads[c]).max() == 0.0
    # The disk does lift-free sliding with theta varying, so eq. (4) is exercised.
    assert np.ptp(traj.q[:, 4]) > 0.05


def test_sliding_cylinder_loads_match_paper_eq18(indep_kinematics):
    """``F_c = m g E3`` at the center of mass and ``M_c = I_a psi' phi' (cos(phi) e1 - sin(phi) e2)`` (eq. 18).

    Derivation (theta = pi/2, so ``omega = psi' E3 + phi' e3`` and ``E3 x e3 = g_2 =
    cos(phi) e1 - sin(phi) e2``): ``H = I_t psi' E3 + I_a phi' e3``;
    ``dH/dt = I_t psi'' E3 + I_a phi'' e3 + I_a phi' psi' E3 x e3`` and the moment about
    the center of mass is ``M_c = lambda_2 (e3 x E3)``, so ``psi'' = phi'' = 0`` and
    ``M_c = I_a psi' phi' (cos(phi) e1 - sin(phi) e2)``, as printed.
    """
    scene = build_scene("sliding_cylinder")
    p = scene.model.parameters
    m, r, g = p["mass"], p["radius"], p["gravity"]
    Ia = m * r**2 / 2
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 3.0)
    loads = traj.loads()
    F = np.column_stack([loads[f"plane.F_{a}"] for a in "xyz"])
    M = np.column_stack([loads[f"plane.M_{a}"] for a in "xyz"])
    point = np.column_stack([loads[f"plane.point_{a}"] for a in "xyz"])
    f = _independent_rate_functions(indep_kinematics)
    err_F = err_M = err_rates = 0.0
    for k in range(len(traj)):
        rates, _, e1, e2, _ = (np.asarray(x).ravel() for x in f(traj.q[k], traj.u[k], traj.udot[k]))
        psi_dot, phi_dot, phi = rates[0], rates[2], traj.q[k, 5]
        F_expected = np.array([0.0, 0.0, m * g])
        M_expected = Ia * psi_dot * phi_dot * (np.cos(phi) * e1 - np.sin(phi) * e2)
        err_F = max(err_F, np.abs(F[k] - F_expected).max() / (m * g))
        err_M = max(err_M, np.abs(M[k] - M_expected).max() / (Ia * abs(psi_dot * phi_dot)))
        # psi'' = phi'' = 0 (derivation above): the rates stay at their initial values.
        err_rates = max(err_rates, abs(psi_dot - p["psi_dot0"]), abs(phi_dot - p["phi_dot0"]))
    assert err_F <= 1e-8
    assert err_M <= 1e-8
    # F_c acts at the center of mass (Table 1).
    assert np.abs(point - traj.q[:, 0:3]).max() <= 1e-15
    assert err_rates <= 1e-9
