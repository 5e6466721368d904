"""Newton-Euler with Lagrange's prescription equals Lagrange's equations with multipliers (secs. 1, 5).

For the sliding disk and the whirling body, an independent Lagrangian model is built
here with CasADi from the scene's numbers alone: ``T(q, q')`` with
``omega = axial(Qdot Q^T)`` of a hand-written 3-1-3 rotation tensor and ``vbar = xbar'``,
``U = m g z``, and the constraints written directly in the coordinates
(``A(q) q' + e(q, t) = 0``). Its equations

    d/dt(dT/dq') - dT/dq + dU/dq = A^T lambda,      A q'' + d/dt(A) q' + de/dt = 0,

are solved for ``q''`` and ``lambda`` and compared with the library's speeds'
derivatives (mapped to ``q''`` through the same independent kinematics) and
multipliers, at states along simulated motions and at random consistent states.
The generalized constraint forces ``Phi = lambda A`` (eqs. 38-41) and, in the paper's
adapted coordinates, ``Phi = lambda delta^6`` (eqs. 3, 44) are checked too.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.scenes.registry import build_scene

TOL = 1e-9


class IndependentLagrangian:
    """Lagrange's equations with multipliers for one rigid body with 3-1-3 angles.

    ``q = (x, y, z, psi, theta, phi)`` (the library's coordinate order);
    ``constraints(q, qd, t)`` returns the constraint functions ``A(q) qd + e(q, t)``.
    """

    def __init__(self, kin, mass, inertia, gravity, constraints):
        q, qd, t = ca.SX.sym("q", 6), ca.SX.sym("qd", 6), ca.SX.sym("t")
        angles, rates = q[3:6], qd[3:6]
        Q = kin.rotation_of_sequence("313", angles)
        omega = kin.omega_from_rotation(Q, angles, rates)
        J = Q @ ca.DM(inertia) @ Q.T
        T = 0.5 * mass * ca.dot(qd[0:3], qd[0:3]) + 0.5 * ca.dot(omega, J @ omega)
        U = mass * gravity * q[2]
        p = ca.gradient(T, qd)
        Mq = ca.jacobian(p, qd)
        # d/dt(dT/dq') = Mq q'' + (dp/dq) q';   Mq q'' = rhs + A^T lambda
        rhs = ca.gradient(T, q) - ca.gradient(U, q) - ca.jacobian(p, q) @ qd
        pi = constraints(q, qd, t)
        A = ca.jacobian(pi, qd)
        e = ca.substitute(pi, qd, ca.SX.zeros(6))
        gamma = ca.jacobian(pi, q) @ qd + ca.jacobian(pi, t)
        nc = pi.numel()
        K = ca.blockcat(Mq, -A.T, A, ca.SX.zeros(nc, nc))
        self.nc = nc
        self.kkt = ca.Function("kkt", [q, qd, t], [K, ca.vertcat(rhs, -gamma)])
        self.A = ca.Function("A", [q, t], [A])
        self.e = ca.Function("e", [q, t], [e])
        W = ca.jacobian(omega, rates)  # omega = W angles'
        self.W = ca.Function("W", [q], [W])
        self.Wdot_rates = ca.Function("Wdot", [q, qd], [ca.jtimes(W @ rates, q, qd)])

    def solve(self, q, qd, t):
        K, b = (np.asarray(x) for x in self.kkt(q, qd, t))
        z = np.linalg.solve(K, b.ravel())
        return z[:6], z[6:]

    def speeds(self, q, qd):
        """Library speeds ``u = (vbar, omega)`` of the coordinate rates."""
        return np.concatenate([qd[0:3], np.asarray(self.W(q)) @ qd[3:6]])

    def rates(self, q, u):
        return np.concatenate([u[0:3], np.linalg.solve(np.asarray(self.W(q)), u[3:6])])

    def accelerations(self, q, u, udot):
        """``q''`` from the library's ``u'``: ``omega' = W angles'' + (dW/dt) angles'``."""
        qd = self.rates(q, u)
        wdot = np.asarray(self.Wdot_rates(q, qd)).ravel()
        return np.concatenate([udot[0:3], np.linalg.solve(np.asarray(self.W(q)), udot[3:6] - wdot)])


# -- the two bodies ---------------------------------------------------------------------
def _disk_lagrangian(kin, params):
    m, R = params["mass"], params["radius"]
    inertia = np.diag([m * R**2 / 4, m * R**2 / 4, m * R**2 / 2])

    def constraints(q, qd, t):
        # z_P = z - R sin(theta) = 0 at velocity level (paper sec. 1).
        return qd[2] - R * ca.cos(q[4]) * qd[4]

    return IndependentLagrangian(kin, m, inertia, params["gravity"], constraints)


def _whirling_geometry(params):
    com = np.array([params["com_x"], params["com_y"], params["com_z"]])
    J = np.array([[params["J11"], params["J12"], params["J13"]],
                  [params["J12"], params["J22"], params["J23"]],
                  [params["J13"], params["J23"], params["J33"]]])
    return com, J


def _whirling_omega(params, t):
    return params["omega"] + params["omega_amplitude"] * ca.sin(t)


def _whirling_lagrangian(kin, params):
    com, J = _whirling_geometry(params)

    def constraints(q, qd, t):
        # X_A at body-basis offset -com from the center of mass stays at the origin.
        x_A = q[0:3] - kin.rotation_of_sequence("313", q[3:6]) @ ca.DM(com)
        return ca.vertcat(ca.jacobian(x_A, q) @ qd, qd[3] - _whirling_omega(params, t), qd[5])

    return IndependentLagrangian(kin, params["mass"], J, params["gravity"], constraints)


def _random_disk_states(params, n, seed):
    rng = np.random.default_rng(seed)
    R = params["radius"]
    for _ in range(n):
        theta = rng.uniform(0.3, math.pi - 0.3)
        q = np.array([*rng.normal(size=2), R * math.sin(theta), rng.uniform(-3, 3), theta, rng.uniform(-3, 3)])
        qd = rng.normal(size=6) * np.array([0.5, 0.5, 0, 3, 1, 10])
        qd[2] = R * math.cos(theta) * qd[4]
        yield q, qd, rng.uniform(0, 10)


def _random_whirling_states(kin, params, n, seed):
    rng = np.random.default_rng(seed)
    com, _ = _whirling_geometry(params)
    a, ad = ca.SX.sym("a", 3), ca.SX.sym("ad", 3)
    Qc = kin.rotation_of_sequence("313", a) @ ca.DM(com)
    xbar = ca.Function("xbar", [a, ad], [Qc, ca.jtimes(Qc, a, ad)])
    for _ in range(n):
        t = rng.uniform(0, 10)
        angles = np.array([rng.uniform(-3, 3), rng.uniform(0.3, math.pi - 0.3), 0.0])
        rates = np.array([float(_whirling_omega(params, t)), rng.normal() * 2, 0.0])
        x, xd = (np.asarray(v).ravel() for v in xbar(angles, rates))
        yield np.concatenate([x, angles]), np.concatenate([xd, rates]), t


# -- comparisons ------------------------------------------------------------------------
def _compare_at(eqs, lag, q, u, t, udot_lib=None, lam_lib=None):
    """Largest relative differences in ``q''`` and ``lambda`` and in ``Phi``."""
    if udot_lib is None:
        udot_lib, lam_lib = (np.asarray(x).ravel() for x in eqs.forward_dynamics(q, u, t, [], []))
    qd = lag.rates(q, u)
    qdd_lag, lam_lag = lag.solve(q, qd, t)
    qdd_lib = lag.accelerations(q, u, udot_lib)
    err_qdd = np.abs(qdd_lib - qdd_lag).max() / max(1.0, np.abs(qdd_lag).max())
    err_lam = np.abs(lam_lib - lam_lag).max() / max(1.0, np.abs(lam_lag).max())
    # Phi_Gamma = lambda_k A_k,Gamma (eqs. 38-41), per constraint.
    phi_lib = eqs.generalized_constraint_forces(q, lam_lib, t)
    phi_ind = lam_lib.reshape(-1, 1) * np.asarray(lag.A(q, t))
    err_phi = np.abs(phi_lib - phi_ind).max() / max(1.0, np.abs(phi_ind).max())
    return err_qdd, err_lam, err_phi


def _max_error_along(eqs, lag, traj, every: int) -> float:
    """Largest of the ``_compare_at`` errors at every ``every``-th sample of a simulated run."""
    return float(np.max([_compare_at(eqs, lag, traj.q[k], traj.u[k], traj.t[k], traj.udot[k], traj.lam[k])
                         for k in range(0, len(traj), every)]))


def test_sliding_disk_newton_euler_equals_lagrange_along_simulated_motion(physics_sliding_disk_10s, indep_kinematics):
    """Along the 10 s sliding-disk run: same ``q''`` and the same normal-force multiplier."""
    scene, eqs, traj = physics_sliding_disk_10s
    assert _max_error_along(eqs, _disk_lagrangian(indep_kinematics, scene.model.parameters), traj, 25) <= TOL


def test_sliding_disk_newton_euler_equals_lagrange_at_random_states(indep_kinematics):
    """At random states on the constraint manifold (random height-consistent q, random q')."""
    scene = build_scene("sliding_disk")
    eqs = SystemEquations(scene.model)
    p = scene.model.parameters
    lag = _disk_lagrangian(indep_kinematics, p)
    errs = []
    for q, qd, t in _random_disk_states(p, 25, seed=1):
        u = lag.speeds(q, qd)
        # The library's constraint agrees with z' - R cos(theta) theta' = 0 at this state.
        assert abs(float(eqs.constraint_functions(q, u, t, [])[3])) <= 1e-14 * max(1, np.abs(u).max())
        errs.append(_compare_at(eqs, lag, q, u, t))
    assert np.max(errs) <= TOL


def test_whirling_newton_euler_equals_lagrange_along_simulated_motion(physics_whirling_varying_3s, indep_kinematics):
    """Whirling body with ``Omega(t) = 2 + 0.5 sin(t)``: same ``q''`` and the same five multipliers."""
    scene, eqs, traj = physics_whirling_varying_3s
    assert eqs.constraint_names == ["shaft.v1", "shaft.v2", "shaft.v3", "shaft.drive", "shaft.lock"]
    assert _max_error_along(eqs, _whirling_lagrangian(indep_kinematics, scene.model.parameters), traj, 15) <= TOL


def test_whirling_newton_euler_equals_lagrange_at_random_states(indep_kinematics):
    """Random ``psi, theta, theta'``, ``t``; ``psi' = Omega(t)``, ``phi = phi' = 0``, ``v_A = 0``."""
    scene = build_scene("whirling", {"omega_amplitude": 0.5})
    eqs = SystemEquations(scene.model)
    p = scene.model.parameters
    lag = _whirling_lagrangian(indep_kinematics, p)
    errs = []
    for q, qd, t in _random_whirling_states(indep_kinematics, p, 25, seed=2):
        u = lag.speeds(q, qd)
        _, _, phi, pi, _ = eqs.constraint_functions(q, u, t, [])
        assert np.abs(np.asarray(pi)).max() <= 1e-13 * max(1, np.abs(u).max())
        errs.append(_compare_at(eqs, lag, q, u, t))
    assert np.max(errs) <= TOL


def test_disk_generalized_constraint_force_is_lambda_delta6_in_paper_coordinates():
    """Paper eq. (3): with ``q = (x, y, psi, theta, phi, z_P)``, ``Phi_Gamma = lambda delta^6_Gamma``."""
    scene = build_scene("sliding_disk")
    eqs = SystemEquations(scene.model)
    R = scene.model.parameters["radius"]
    p = ca.SX.sym("p", 6)  # (x, y, psi, theta, phi, z_P)
    to_q = ca.Function("to_q", [p], [ca.vertcat(p[0], p[1], p[5] + R * ca.sin(p[3]), p[2], p[3], p[4])])
    rng = np.random.default_rng(5)
    for _ in range(10):
        pv = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(0.3, 2.8), rng.uniform(-3, 3), 0.0])
        lam = rng.normal() * 10
        phi = eqs.generalized_constraint_forces(pv, [lam], 0.0, coordinates=to_q)
        assert np.abs(phi - lam * np.eye(6)[5]).max() <= 1e-13 * abs(lam)


def test_whirling_generalized_constraint_forces_are_kronecker_deltas_in_adapted_coordinates(indep_kinematics):
    """Paper eq. (44): with ``p = (x_A, psi, theta, phi)`` each constraint acts on its own coordinate only."""
    scene = build_scene("whirling", {"omega_amplitude": 0.5})
    eqs = SystemEquations(scene.model)
    com, _ = _whirling_geometry(scene.model.parameters)
    p = ca.SX.sym("p", 6)
    xbar = p[0:3] + indep_kinematics.rotation_of_sequence("313", p[3:6]) @ ca.DM(com)
    to_q = ca.Function("to_q", [p], [ca.vertcat(xbar, p[3:6])])
    rng = np.random.default_rng(6)
    expected_columns = [0, 1, 2, 3, 5]  # x_A, y_A, z_A, psi, phi
    for _ in range(10):
        pv = np.array([*rng.normal(size=3), rng.uniform(-3, 3), rng.uniform(0.3, 2.8), rng.uniform(-3, 3)])
        lam = rng.normal(size=5) * 10
        phi = eqs.generalized_constraint_forces(pv, lam, rng.uniform(0, 10), coordinates=to_q)
        expected = np.zeros((5, 6))
        expected[np.arange(5), expected_columns] = lam
        assert np.abs(phi - expected).max() <= 1e-12 * np.abs(lam).max()
