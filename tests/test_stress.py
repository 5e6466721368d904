"""Numerical-stability stress cases (the fast ones; the slow ones run in ``ocp-constraints bench``).

Euler singularities (detection, and the quaternion parameterization against a closed
form through theta = 0), high spin, loads under dimensional scaling, properties on
random bodies and constraints (hypothesis), and IPOPT's hard cases. A case that fails
physically must fail with a message, never with NaNs in the results.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from ocp_constraints import joints
from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.errors import RedundantConstraintsError, SimulationError
from ocp_constraints.mechanics.model import Model
from ocp_constraints.errors import OCPSolveError
from ocp_constraints.errors import SingularConfigurationError
from ocp_constraints.scenes.registry import build_scene, build_task
from ocp_constraints.dynamics.simulate import SimulationOptions, simulate
from ocp_constraints.mechanics.state import consistent_state
from ocp_constraints.scenes.tasks import energy_balance
from ocp_constraints.ocp.schemes import Radau

M_ROD, L_ROD, G = 1.0, 1.0, 9.81


# -- Euler singularity --------------------------------------------------------------------------
def _rod_about_E1(rotation: str, theta0: float):
    """A rod hinged at the origin about E1, hanging along -E3 at theta = 0 (so 3-1-3's theta is the swing angle)."""
    model = Model("rod_E1", gravity=(0.0, 0.0, -G))
    d = np.array([0.0, 0.0, -1.0])
    rod = model.add_body("rod", M_ROD, M_ROD * L_ROD**2 / 12 * (np.eye(3) - np.outer(d, d)), rotation=rotation)
    A = rod.point("A", -L_ROD / 2 * d)
    joints.revolute(model, "hinge", A, axis=(1, 0, 0))
    c, s = math.cos(theta0), math.sin(theta0)
    xbar = L_ROD / 2 * np.array([0.0, s, -c])  # R1(theta0) (L/2) d
    coords = {"rod.x": xbar[0], "rod.y": xbar[1], "rod.z": xbar[2]}
    if rotation == "quaternion":
        coords.update({"rod.qw": math.cos(theta0 / 2), "rod.qx": math.sin(theta0 / 2), "rod.qy": 0.0, "rod.qz": 0.0})
        rates = {"rod.omega_x": 0.0}
    else:
        coords.update({"rod.psi": 0.0, "rod.theta": theta0, "rod.phi": 0.0})
        rates = {"rod.theta_dot": 0.0}
    return model, coords, rates


@pytest.mark.parametrize("theta", [1e-4, 1e-6, 0.0, -1e-6])
def test_313_near_singularity_is_detected_with_a_message(theta):
    model, coords, rates = _rod_about_E1("313", theta)
    with pytest.raises(SingularConfigurationError, match="quaternion") as info:
        consistent_state(SystemEquations(model), coords, rates)
    assert "'313'" in str(info.value) and "theta" in str(info.value)


def test_313_regular_close_to_singularity_still_works():
    model, coords, rates = _rod_about_E1("313", 1e-2)
    eqs = SystemEquations(model)
    q0, u0 = consistent_state(eqs, coords, rates)
    assert np.all(np.isfinite(np.asarray(eqs.forward_dynamics(q0, u0, 0.0, [], [])[1])))


def test_313_motion_through_theta_zero_stops_with_message_and_finite_partial_results():
    model, coords, rates = _rod_about_E1("313", 0.5)
    eqs = SystemEquations(model)
    q0, u0 = consistent_state(eqs, coords, rates)
    # The check runs at output samples: sample finely enough to land inside |sin theta| < 1e-3.
    with pytest.raises(SimulationError, match="quaternion") as info:
        simulate(eqs, q0, u0, 0.6, SimulationOptions(dt=1e-4))
    partial = info.value.partial
    assert partial is not None and 0 < len(partial) and partial.t[-1] < 0.5
    assert np.all(np.isfinite(partial.q)) and np.all(np.isfinite(partial.lam))
    assert np.all(np.abs(partial.q[:, 4]) > 0)  # every kept sample is on one side of theta = 0


def test_quaternion_rod_through_theta_zero_matches_closed_form_loads():
    """``theta'^2 = 3g/L (cos theta - cos theta0)``, ``theta'' = -3g/(2L) sin theta`` (energy and
    the balance about the hinge); ``F = m r'' - m g_vec`` with ``r = L/2 (0, sin theta, -cos theta)``."""
    theta0 = 0.5
    model, coords, rates = _rod_about_E1("quaternion", theta0)
    eqs = SystemEquations(model)
    q0, u0 = consistent_state(eqs, coords, rates)
    traj = simulate(eqs, q0, u0, 2.0)
    q = traj.q
    theta = 2 * np.arctan2(q[:, 4], q[:, 3])
    assert theta.min() < -0.4 and theta.max() > 0.4  # it swings through theta = 0
    sign = np.sign(traj.u[:, 3])
    rate = sign * np.sqrt(np.maximum(3 * G / L_ROD * (np.cos(theta) - math.cos(theta0)), 0.0))
    acc = -1.5 * G / L_ROD * np.sin(theta)
    h = L_ROD / 2
    Fy = M_ROD * h * (acc * np.cos(theta) - rate**2 * np.sin(theta))
    Fz = M_ROD * h * (acc * np.sin(theta) + rate**2 * np.cos(theta)) + M_ROD * G
    loads = traj.loads()
    scale = M_ROD * G
    assert np.abs(loads["hinge.F_x"]).max() <= 1e-9 * scale
    assert np.abs(loads["hinge.F_y"] - Fy).max() <= 1e-7 * scale
    assert np.abs(loads["hinge.F_z"] - Fz).max() <= 1e-7 * scale
    # A planar rod needs no constraint moment about E2 and E3.
    assert np.abs(np.column_stack([loads["hinge.M_y"], loads["hinge.M_z"]])).max() <= 1e-8 * scale * L_ROD


# -- high spin ---------------------------------------------------------------------------------
@pytest.mark.parametrize("omega", [10.0, 100.0, 1000.0])
def test_high_spin_whirling_energy_balance_and_residuals(omega):
    scene = build_scene("whirling", {"omega": omega})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    t_final = 6 * 2 * math.pi / omega if omega > 10 else 1.0  # a few shaft turns
    # Project back onto the constraints ten times per run (the default, every 0.5 s, is a long time at 1e3 rad/s).
    traj = simulate(eqs, q0, u0, t_final, SimulationOptions(dt=t_final / 200, projection_interval=t_final / 10))
    assert np.all(np.isfinite(traj.lam))
    energy = energy_balance(traj)
    assert energy["relative_error"] <= 1e-6  # measured: 3e-7 to 6e-7 at Omega = 100 and 1000
    pos, vel = traj.residuals()
    assert pos <= 1e-7  # drift before projection
    assert vel <= 1e-7 * omega
    # The joint's power is the motor's lambda_4 Omega (eq. 27), up to lambda times the velocity residual.
    loads = traj.loads()
    assert np.allclose(loads["shaft.power"], traj.sample("shaft.drive.lambda") * omega, rtol=0,
                       atol=1e-6 * np.abs(loads["shaft.power"]).max())


def test_drift_stays_bounded_at_high_spin_with_the_default_projection_interval():
    # At 1e3 rad/s a 0.5 s segment drifts to 6e-6 (position) before its projection; the
    # segment is then integrated again in halves, so the drift stays near the tolerance.
    scene = build_scene("whirling", {"omega": 1000.0})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 0.1, SimulationOptions(dt=1e-3))
    pos, vel = traj.residuals()  # including the residuals just before each projection
    assert pos <= 1e-7 and vel <= 5e-8 * np.abs(traj.u).max()
    assert energy_balance(traj)["relative_error"] <= 1e-6


# -- dimensional scaling -------------------------------------------------------------------------
def _pendulum_loads(mass: float, length: float, gravity: float, t_final: float = 1.0):
    scene = build_scene("pendulum", {"mass": mass, "length": length, "gravity": gravity})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    atol = 1e-12 * max(1.0, length)
    return simulate(eqs, q0, u0, t_final, SimulationOptions(atol=atol)).multiplier_columns()


@pytest.mark.parametrize("a, b", [(1e-3, 1.0), (1e3, 1.0), (1.0, 1e-3), (1.0, 1e3),
                                  (1e-3, 1e3)])
def test_pendulum_loads_scale_as_dimensional_analysis_says(a, b):
    """Mass x a, length x b and gravity x b keep sqrt(L/g), so the motion in time is unchanged:
    forces scale with m L / T^2 (x a b) and moments with m L^2 / T^2 (x a b^2), pointwise."""
    base = _pendulum_loads(1.0, 1.0, G)
    scaled = _pendulum_loads(a, b, G * b)
    scale = max(np.abs(v).max() for v in base.values())
    for name, values in base.items():
        factor = a * b**2 if ".w" in name else a * b
        assert np.abs(scaled[name] / factor - values).max() <= 1e-8 * scale, name


# -- properties on random bodies, points and constraints (hypothesis) ----------------------------
def _rotation(v) -> np.ndarray:
    """Rotation matrix of the rotation vector ``v`` (Rodrigues)."""
    v = np.asarray(v, float)
    a = np.linalg.norm(v)
    if a < 1e-12:
        return np.eye(3)
    k = v / a
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


def _quaternion(R) -> np.ndarray:
    from ocp_constraints.mechanics.rotations import quaternion_from_rotation

    return quaternion_from_rotation(R)


vec3 = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)


@st.composite
def random_system(draw):
    principal = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=3, max_size=3)))
    assume(principal.sum() - 2 * principal.max() > 0.05)  # triangle inequality with margin
    return {
        "mass": draw(st.floats(0.1, 10.0)),
        "J": (lambda Rj: Rj @ np.diag(principal) @ Rj.T)(_rotation(draw(vec3) * 3)),
        "rA": draw(vec3),
        "rP": draw(vec3),
        "normal": draw(vec3),
        "Q0": _rotation(draw(vec3) * 3),
        "omega": draw(vec3) * 3,
        "gravity": draw(vec3) * 10,
        "R": _rotation(draw(vec3) * 3),
    }


def _build(s: dict, R: np.ndarray):
    """Ball-and-socket at X_A to the origin plus a moving sliding contact ``n . v_P = 0.3 sin t``."""
    n = R @ s["normal"]
    assume(np.linalg.norm(n) > 0.2)
    model = Model("random", gravity=tuple(R @ s["gravity"]))
    body = model.add_body("body", s["mass"], s["J"], rotation="quaternion")
    A = body.point("A", s["rA"])
    P = body.point("P", s["rP"])
    joints.ball_and_socket(model, "ball", A)
    joints.sliding_contact(model, "slide", P, normal=n, rate=0.3 * ca.sin(model.t), height=None)
    Q0 = R @ s["Q0"]
    xbar = -Q0 @ s["rA"]
    om = R @ s["omega"]
    coords = {"body.x": xbar[0], "body.y": xbar[1], "body.z": xbar[2]}
    coords.update(dict(zip(("body.qw", "body.qx", "body.qy", "body.qz"), _quaternion(Q0))))
    eqs = SystemEquations(model)
    t0 = 1.0
    try:
        q0, u0 = consistent_state(eqs, coords, {}, t0=t0)
    except RedundantConstraintsError:
        assume(False)
    # Add a rigid rotation about the ball joint that the constraints allow: project om onto them.
    G, e, *_ = (np.asarray(x) for x in eqs.constraint_functions(q0, u0, t0, []))
    u_try = np.concatenate([np.cross(om, xbar), om])  # rigid rotation about X_A at the origin
    Z = np.linalg.svd(G)[2][G.shape[0]:].T
    u0 = u0 + Z @ (Z.T @ (u_try - u0))
    return eqs, q0, u0, t0, body, A, P


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(random_system())
def test_power_identity_equipollence_phi_and_frame_invariance(s):
    eqs, q, u, t, body, A, P = _build(s, np.eye(3))
    udot, lam = (np.asarray(x).ravel() for x in eqs.forward_dynamics(q, u, t, [], []))
    assert np.all(np.isfinite(lam))
    G, e, _, pi, _ = (np.asarray(x) for x in eqs.constraint_functions(q, u, t, []))
    e = e.ravel()
    assert np.abs(pi).max() <= 1e-9 * max(1.0, np.abs(u).max())
    loads = np.asarray(eqs.loads_function(q, u, t, lam)).ravel().reshape(-1, 10)  # per joint: F, M, point, power
    names = eqs.constraint_names
    scale = max(1.0, np.abs(lam).max()) * max(1.0, np.abs(u).max())
    # Power identity (eq. 27): F . v_C + M . omega = -sum_k lambda_k e_k over each joint.
    for ch, row in zip(eqs.load_channels, loads):
        k = [i for i, c in enumerate(names) if c.startswith(ch.joint + ".")]
        assert abs(row[9] + float(lam[k] @ e[k])) <= 1e-9 * scale
    # Equipollence (eqs. 32-33): the contact load moved to X_A, by hand.
    F, M, xP = loads[1, 0:3], loads[1, 3:6], loads[1, 6:9]
    F_A, M_A = (np.asarray(x).ravel() for x in eqs.load_about_function("slide", A)(q, u, t, lam))
    xA = np.asarray(ca.Function("xA", [eqs.q], [A.position])(q)).ravel()
    assert np.allclose(F_A, F, atol=1e-12 * scale)
    assert np.allclose(M_A, M + np.cross(xP - xA, F), atol=1e-10 * scale)
    # Phi = lambda A (eqs. 38-41): its virtual power with q' equals each constraint's power lambda_k G_k u.
    Phi = eqs.generalized_constraint_forces(q, lam, t)
    qdot = np.asarray(eqs.coordinate_rates(q, u)).ravel()
    assert np.allclose(Phi @ qdot, lam * (G @ u), atol=1e-9 * scale)
    # Frame invariance: rotate gravity, the contact normal and the state by R: loads rotate by R.
    R = s["R"]
    eqs2, q2, u2, _, _, _, _ = _build(s, R)
    u2 = np.concatenate([R @ u[0:3], R @ u[3:6]])
    lam2 = np.asarray(eqs2.forward_dynamics(q2, u2, t, [], [])[1]).ravel()
    loads2 = np.asarray(eqs2.loads_function(q2, u2, t, lam2)).ravel().reshape(-1, 10)
    for a, b in zip(loads, loads2):
        assert np.allclose(b[0:3], R @ a[0:3], atol=1e-8 * scale)
        assert np.allclose(b[3:6], R @ a[3:6], atol=1e-8 * scale)
        assert np.allclose(b[6:9], R @ a[6:9], atol=1e-10)
    assert abs(lam2[3] - lam[3]) <= 1e-8 * scale  # the contact's multiplier is a scalar


# -- IPOPT hard cases ------------------------------------------------------------------------------
def _swing_up(overrides=None):
    return build_task("pendulum", "swing_up", overrides)[1]


def test_infeasible_start_and_problem_fail_clearly_and_keep_last_iterate():
    problem = _swing_up({"max_torque": 0.5})  # cannot lift the rod (m g L / 2 = 4.9 N m)
    with pytest.raises(OCPSolveError, match="IPOPT did not solve 'pendulum'") as info:
        problem.solve(Radau(10, degree=3))
    sol = info.value.solution
    assert not sol.success and sol.iterations > 0
    assert "Infeasible" in sol.status or "Restoration" in sol.status or "Maximum" in sol.status
    assert np.all(np.isfinite(sol.decision_vector))
    assert np.all(np.isfinite(sol.X)) and np.all(np.abs(sol.inputs) <= 0.5 + 1e-8)


def test_iteration_limit_keeps_last_iterate():
    with pytest.raises(OCPSolveError, match="Maximum_Iterations_Exceeded") as info:
        _swing_up().solve(Radau(10, degree=3), {"ipopt.max_iter": 3})
    sol = info.value.solution
    assert sol.iterations == 3 and np.all(np.isfinite(sol.decision_vector))


def test_restoration_phase_start_reaches_the_same_optimum():
    # N = 20: at N = 10 the two starts land in different local optima (13.68 and 8.95),
    # which says nothing about the restoration phase.
    plain = _swing_up().solve(Radau(20, degree=3))
    resto = _swing_up().solve(Radau(20, degree=3), {"ipopt.start_with_resto": "yes"})
    assert resto.success
    assert resto.objective == pytest.approx(plain.objective, rel=1e-6)


def _swing_up_extremal_from(psi_guess: float, p: dict, t_final: float):
    """Objective and torque of the swing-up extremal that Pontryagin's conditions give from ``psi = psi_guess``.

    ``J_A psi'' = tau - c sin(psi)`` (``J_A = m L^2 / 3``, ``c = m g L / 2``), ``min int tau^2``:
    ``tau = -p2 / (2 J_A)``, ``p1' = p2 c cos(psi) / J_A``, ``p2' = -p1``, ``psi: 0 -> pi`` at rest.
    SciPy's collocation BVP solver from the constant guess, then shooting on ``(p1, p2)(0)`` with
    DOP853 at rtol 1e-13: no library code.
    """
    from scipy.integrate import solve_bvp, solve_ivp

    J, c = p["mass"] * p["length"] ** 2 / 3, p["mass"] * p["gravity"] * p["length"] / 2

    def rhs(_, y):
        psi, w, p1, p2 = y[:4]
        return np.array([w, (-p2 / (2 * J) - c * np.sin(psi)) / J, p2 * c * np.cos(psi) / J, -p1, (p2 / (2 * J)) ** 2])

    t = np.linspace(0.0, t_final, 41)
    guess = np.vstack([np.full_like(t, psi_guess), np.zeros((3, t.size))])
    bvp = solve_bvp(lambda t, y: rhs(t, y)[:4], lambda a, b: np.array([a[0], a[1], b[0] - math.pi, b[1]]), t, guess,
                    tol=1e-8, max_nodes=100000)
    assert bvp.status == 0, bvp.message

    def run(p0):
        return solve_ivp(rhs, (0.0, t_final), [0.0, 0.0, *p0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
                         dense_output=True)

    def end(p0):
        y = run(p0).y[:, -1]
        return np.array([y[0] - math.pi, y[1]])

    p0 = bvp.sol(0.0)[2:]
    for _ in range(10):
        r = end(p0)
        if np.abs(r).max() < 1e-11:
            break
        jac = np.column_stack([(end(p0 + d) - end(p0 - d)) / 2e-7 for d in np.eye(2) * 1e-7])
        p0 = p0 - np.linalg.solve(jac, r)
    assert np.abs(end(p0)).max() < 1e-11
    sol = run(p0)
    return sol.y[4, -1], lambda times: -sol.sol(times)[3] / (2 * J)


def test_poor_initial_guess_converges_to_the_extremal_pontryagin_gives_from_it():
    # From psi = 3 everywhere (far from both boundary values) IPOPT must converge, and to the
    # local optimum that Pontryagin's conditions reach from the same guess: the one-way swing,
    # objective 13.670837 (the two-way swing of the default guess is 8.913005).
    problem = _swing_up()
    problem.guess.clear()
    problem.set_guess("rod.psi", lambda t: 0.0 * t + 3.0)
    sol = problem.solve(Radau(10, degree=6))
    assert sol.success, sol.status
    pos, vel = sol.residuals()
    assert pos <= 1e-8 and vel <= 1e-8
    assert np.all(np.isfinite(sol.lam))
    objective, torque = _swing_up_extremal_from(3.0, problem.model.parameters, problem.t_final)
    assert objective == pytest.approx(13.670837, abs=1e-6)
    # Radau 6 on 10 intervals: objective error 4.4e-7 on the faster two-way swing
    # (tests/test_ocp_reference.py), 4e-8 measured here. Torque: measured 2.4e-4 N m, bound 1e-3 N m
    # (2e-4 of its 5.2 N m peak).
    assert abs(sol.objective - objective) <= 1e-6
    assert np.abs(sol.sample("motor") - torque(sol.t)).max() <= 1e-3
