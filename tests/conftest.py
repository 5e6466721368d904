"""Shared pieces of the physics verification tests.

Everything here is written *independently* of ``ocp_constraints``: rotation tensors are
multiplied out by hand, the angular velocity is the axial vector of ``Qdot Q^T``
(paper sec. 2) with ``Qdot`` from CasADi's Jacobian of ``Q`` with respect to the
rotation parameters, and the 3-1-3 dual Euler basis is the explicit formula of paper
eq. (11). The tests compare the library against these.

Fixtures defined here are prefixed ``indep_`` (independent kinematics) or
``physics_`` (shared simulated runs) so that other fixtures can live beside them.
"""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import pytest

from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.scenes.registry import build_scene
from ocp_constraints.dynamics.simulate import simulate
from ocp_constraints.mechanics.state import consistent_state


# -- independent rotation kinematics ------------------------------------------------------
def _rot(axis: int, a):
    """Right-handed rotation by ``a`` about ``E_axis``, written out by hand."""
    c, s = ca.cos(a), ca.sin(a)
    if axis == 1:
        return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))
    if axis == 2:
        return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def _rotation_of_sequence(axes: str, angles):
    """``Q = R_i(a1) R_j(a2) R_k(a3)`` for the sequence ``axes`` (e.g. ``"313"``)."""
    return _rot(int(axes[0]), angles[0]) @ _rot(int(axes[1]), angles[1]) @ _rot(int(axes[2]), angles[2])


def _quaternion_rotation(qv):
    """Rotation tensor of a (not necessarily unit) quaternion ``(w, x, y, z)``.

    Written as ``Q = (w^2 - v.v) I + 2 v v^T + 2 w [v]_x`` divided by ``|q|^2``
    (Euler-Rodrigues), which is a different route from the library's entrywise form.
    """
    w, v = qv[0], qv[1:4]
    skew = ca.vertcat(ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0))
    n2 = ca.dot(qv, qv)
    return ((w * w - ca.dot(v, v)) * ca.SX.eye(3) + 2 * (v @ v.T) + 2 * w * skew) / n2


def _axial(W):
    """Axial vector of the skew part of ``W`` (``w x a = W a``)."""
    return 0.5 * ca.vertcat(W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1])


def _omega_from_rotation(Q, params, rates):
    """``omega = axial(Qdot Q^T)`` with ``Qdot = d(Q)/d(params) . rates`` (paper sec. 2)."""
    Qdot = ca.reshape(ca.jacobian(ca.vec(Q), params) @ rates, 3, 3)
    return _axial(Qdot @ Q.T)


def _dual_basis_313_eq11(angles):
    """Dual Euler basis of 3-1-3 angles exactly as printed in paper eq. (11)."""
    Q = _rotation_of_sequence("313", angles)
    e1, e2, e3 = Q[:, 0], Q[:, 1], Q[:, 2]
    theta, phi = angles[1], angles[2]
    g1 = (ca.cos(phi) * e2 + ca.sin(phi) * e1) / ca.sin(theta)
    g2 = ca.cos(phi) * e1 - ca.sin(phi) * e2
    g3 = e3 - ca.cos(theta) / ca.sin(theta) * (ca.cos(phi) * e2 + ca.sin(phi) * e1)
    return [g1, g2, g3]


def _euler_basis_from_axial(axes: str, angles):
    """Euler basis ``g_i = d(omega)/d(rate_i)`` from ``omega = axial(Qdot Q^T)`` (SX)."""
    rates = ca.SX.sym("rates_indep", 3)
    omega = _omega_from_rotation(_rotation_of_sequence(axes, angles), angles, rates)
    W = ca.jacobian(omega, rates)
    return [W[:, i] for i in range(3)]


@pytest.fixture(scope="session")
def indep_kinematics():
    """Namespace of the independent kinematics helpers above."""
    return SimpleNamespace(
        rot=_rot,
        rotation_of_sequence=_rotation_of_sequence,
        quaternion_rotation=_quaternion_rotation,
        axial=_axial,
        omega_from_rotation=_omega_from_rotation,
        dual_basis_313_eq11=_dual_basis_313_eq11,
        euler_basis_from_axial=_euler_basis_from_axial,
    )


# -- shared simulated runs ----------------------------------------------------------------
@pytest.fixture(scope="session")
def physics_sliding_disk_10s():
    """The default ``sliding_disk`` scene simulated for 10 s: ``(scene, eqs, traj)``."""
    scene = build_scene("sliding_disk")
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 10.0)
    return scene, eqs, traj


@pytest.fixture(scope="session")
def physics_whirling_varying_3s():
    """``whirling`` with ``Omega(t) = 2 + 0.5 sin(t)`` simulated for 3 s: ``(scene, eqs, traj)``."""
    scene = build_scene("whirling", {"omega_amplitude": 0.5})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 3.0)
    return scene, eqs, traj



# -- optimal-control problems shared by several test modules ---------------------------------
def minimum_time_swing_up():
    """The swing-up with free final time in [0.5, 4] s, |torque| <= 5, minimum time."""
    import numpy as np

    from ocp_constraints.ocp.problem import OptimalControlProblem
    from ocp_constraints.scenes.registry import build_task

    _, base = build_task("pendulum", "swing_up")
    problem = OptimalControlProblem(base.model, t_final=2.0, t_final_bounds=(0.5, 4.0))
    problem.bound("motor", -5.0, 5.0)
    problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    problem.final({"rod.psi": np.pi, "rod.psi_dot": 0.0})
    problem.minimize_final_time()
    return base, problem


@pytest.fixture
def ocp_minimum_time_swing_up():
    return minimum_time_swing_up()
