"""One result vocabulary (issue 12): the same question to every result type gets the same answer in the same words.

Each comparison is between two derivations (forward KKT solve against least-squares
inverse dynamics, collocation against Newton's law for the rod's center of mass, eq. 33
worked by hand, Newton's third law across a two-body joint, the static optimisation's
balance equations rebuilt from the named columns), never against the code's earlier output.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints import SystemEquations, build_scene, simulate
from ocp_constraints.biomech.knee_muscles import SECONDARY
from ocp_constraints.biomech.knee_static import RESERVED, solve_static
from ocp_constraints.cli.main import main
from ocp_constraints.dynamics.inverse import InverseDynamics
from ocp_constraints.dynamics.result import Result
from ocp_constraints.errors import ModelError, OCPSolveError, SimulationError
from ocp_constraints.mechanics.load_columns import load_column_names
from ocp_constraints.mechanics.state import consistent_state
from ocp_constraints.ocp.schemes import Radau, Trapezoidal
from ocp_constraints.scenes.registry import build_task
from ocp_constraints.scenes.tasks import simulate_scene

GAIT = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim-gait2354-subject01"


@pytest.fixture(scope="module")
def pendulum():
    scene = build_scene("pendulum")
    return scene, simulate_scene(scene, 0.5)


@pytest.fixture(scope="module")
def pendulum_inverse(pendulum):
    _, traj = pendulum
    return InverseDynamics(traj.eqs).solve(traj.t, traj.q, traj.u, traj.udot)


@pytest.fixture(scope="module")
def swing_up():
    _, problem = build_task("pendulum", "swing_up")
    return problem, problem.solve(Radau(10, degree=3))


def _moved_by_hand(loads: dict, joint: str, x_A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (33) written out: ``M_A = M_C + (x_C - x_A) x F``, from the loads.csv columns."""
    F, M, x_C = (np.column_stack([loads[f"{joint}.{k}_{a}"] for a in "xyz"]) for k in ("F", "M", "point"))
    return F, M + np.cross(x_C - x_A, F)


def test_every_result_type_speaks_the_protocol(pendulum, pendulum_inverse, swing_up):
    _, traj = pendulum
    for result in (traj, pendulum_inverse, swing_up[1]):
        assert isinstance(result, Result)
        assert result.success is True and isinstance(result.status, str) and result.status
    assert traj.status == "completed" and swing_up[1].status == "Solve_Succeeded"
    assert pendulum_inverse.status == "solved"        # square system: the balances hold exactly


def test_simulated_and_inverse_dynamics_give_the_same_loads_in_the_same_words(pendulum, pendulum_inverse):
    """Two derivations of lambda: the forward KKT solve and least squares on the simulated motion."""
    _, traj = pendulum
    sim, inv = traj.loads(), pendulum_inverse.loads()
    assert list(sim) == list(inv) == load_column_names(traj.eqs)
    for name in sim:
        np.testing.assert_allclose(inv[name], sim[name], rtol=0, atol=1e-8, err_msg=name)
    assert traj.sample_names() == pendulum_inverse.sample_names()
    for name in ("rod.psi", "rod.psi_dot", "rod.omega_z", "hinge.w1.lambda"):
        np.testing.assert_allclose(pendulum_inverse.sample(name), traj.sample(name), rtol=0, atol=1e-8, err_msg=name)


def test_load_about_is_eq_33_for_every_result(pendulum, pendulum_inverse, swing_up):
    scene, traj = pendulum
    com = scene.model.bodies["rod"].com
    problem, sol = swing_up
    for result, point in ((traj, com), (pendulum_inverse, com), (sol, problem.model.bodies["rod"].com)):
        x_A = np.column_stack([result.sample(f"rod.{a}") for a in "xyz"])    # the center of mass
        F_hand, M_hand = _moved_by_hand(result.loads(), "hinge", x_A)
        F, M = result.load_about("hinge", point)
        assert F.shape == M.shape == (len(x_A), 3)
        np.testing.assert_allclose(F, F_hand, rtol=0, atol=1e-12)
        np.testing.assert_allclose(M, M_hand, rtol=0, atol=1e-10)
    with pytest.raises(ModelError, match="no joint load 'knee'.*hinge"):
        traj.load_about("knee", com)
    with pytest.raises(ModelError, match="not in model 'pendulum'"):
        sol.load_about("hinge", com)                  # a point of the scene's model, not the problem's


def test_two_body_joint_loads_are_equal_and_opposite_in_every_result():
    """Newton's third law across the ball-and-socket (scene sec. 6): ``<joint>@<body>`` columns."""
    scene = build_scene("ball_socket")
    traj = simulate_scene(scene, 0.2)
    inverse = InverseDynamics(traj.eqs).solve(traj.t, traj.q, traj.u, traj.udot)
    channels = [ch for ch in traj.eqs.load_channels if "@" in ch.prefix]
    assert [ch.prefix for ch in channels] == ["socket_C@body1", "socket_C@body2"]
    (a, body), b = (channels[0].prefix, channels[0].body), channels[1].prefix
    for result in (traj, inverse):
        loads = result.loads()
        for k in ("F_x", "F_y", "F_z"):
            np.testing.assert_allclose(loads[f"{a}.{k}"], -loads[f"{b}.{k}"], rtol=0, atol=1e-9)
        F, M = result.load_about(a, scene.model.bodies[body].com)
        x_A = np.column_stack([result.sample(f"{body}.{c}") for c in "xyz"])
        F_hand, M_hand = _moved_by_hand(loads, a, x_A)
        np.testing.assert_allclose(M, M_hand, rtol=0, atol=1e-9)


def test_ocp_loads_at_its_points_are_newtons_law_and_the_trajectory_of_its_samples(swing_up):
    """Hinge force = m (a_com - g) from the collocated accelerations D (the motor is a pure torque)."""
    problem, sol = swing_up
    model, eqs = problem.model, problem.eqs
    loads = sol.loads()
    assert list(loads) == load_column_names(eqs)
    m = model.bodies["rod"].mass
    F = np.column_stack([loads[f"hinge.F_{a}"] for a in "xyz"])
    np.testing.assert_allclose(F, m * (sol.D[:3].T - np.asarray(model.gravity)), rtol=0, atol=1e-9)
    # An ideal hinge does no work: P = F . v_C + M . omega = -lambda e = 0 (eq. 27).
    assert np.abs(loads["hinge.power"]).max() < 1e-6 * np.abs(F).max()
    # The trajectory built by hand from the same samples answers the same.
    from ocp_constraints.dynamics.trajectory import Trajectory

    traj = Trajectory(eqs)
    for i, t in enumerate(sol.t):
        traj.append(t, sol.X[: eqs.nq, i], sol.X[eqs.nq :, i], sol.D[:, i], sol.lam[:, i], sol.inputs[:, i],
                    np.zeros(eqs.nc), 0.0, 0.0)
    for name, values in traj.loads().items():
        np.testing.assert_allclose(loads[name], values, rtol=0, atol=1e-12, err_msg=name)
    np.testing.assert_allclose(sol.sample("motor"), sol.inputs[0], rtol=0, atol=0)


def test_failed_runs_say_so_in_success_and_status():
    _, problem = build_task("pendulum", "swing_up", {"max_torque": 0.1})
    with pytest.raises(OCPSolveError) as info:
        problem.solve(Trapezoidal(10), {"ipopt.max_iter": 15})
    sol = info.value.solution
    assert sol.success is False and sol.status == sol.stats["return_status"] != "Solve_Succeeded"
    assert sol.trajectory.success is False and sol.trajectory.status == sol.status
    # A 3-1-3 disk falling flat reaches its Euler singularity (as in test_simulate.py).
    scene = build_scene("sliding_disk", {"theta0": 0.3, "psi_dot0": 0.0, "phi_dot0": 0.0, "theta_dot0": -2.0,
                                         "x_dot0": 0.0, "y_dot0": 0.0})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    with pytest.raises(SimulationError) as stopped:
        simulate(eqs, q0, u0, 2.0)
    partial = stopped.value.partial
    assert partial.success is False and partial.status == str(stopped.value)
    assert len(partial.loads()["contact.n.lambda"]) == len(partial)


def test_unknown_names_are_named_with_close_matches(pendulum, pendulum_inverse, swing_up):
    _, traj = pendulum
    for result in (traj, pendulum_inverse, swing_up[1]):
        with pytest.raises(ModelError, match=r"no quantity named 'rod.pssi'.*did you mean 'rod.psi'"):
            result.sample("rod.pssi")
        with pytest.raises(ModelError, match=r"'hinge.w1.lambda'"):
            result.sample("hinge.w1.lamda")


def test_cli_loads_csv_has_exactly_the_columns_loads_returns(tmp_path, pendulum):
    _, traj = pendulum
    assert main(["simulate", "pendulum", "--t-final", "0.1", "--out", str(tmp_path), "--no-plots"]) == 0
    with open(tmp_path / "loads.csv") as f:
        header = next(csv.reader(f))
    assert header == ["t", *traj.loads()]


def test_static_optimisation_names_its_columns_and_has_no_joint_loads():
    """Three frames of a made-up leg: the balance ``Q = R F + A^T lambda + rho`` rebuilt from the names."""
    rng = np.random.default_rng(3)
    rows, muscles = RESERVED + SECONDARY, 4
    N = 3
    R = rng.normal(0.0, 0.03, (N, len(rows), muscles))
    A = rng.normal(0.0, 1.0, (N, 5, len(rows)))
    Qc = rng.normal(0.0, 20.0, (N, len(rows)))
    res = solve_static(np.arange(N) * 0.01, Qc, R, A, np.full(muscles, 1000.0), contact_nonnegative=False)
    res.muscles = [f"m{i}" for i in range(muscles)]
    assert res.success is True and res.status == "Solve_Succeeded"
    force = np.column_stack([res.sample(f"m{i}.force") for i in range(muscles)])
    lam = np.column_stack([res.sample(f"{c}.lambda") for c in
                           ("knee_medial.n", "knee_lateral.n", "knee.ap", "knee.ml", "knee.ie")])
    rho = np.column_stack([res.sample(f"reserve_{c}") for c in RESERVED] + [np.zeros((N, len(SECONDARY)))])
    balance = np.einsum("ncm,nm->nc", R, force) + np.einsum("njc,nj->nc", A, lam) + rho
    np.testing.assert_allclose(balance, Qc, rtol=0, atol=1e-6)
    np.testing.assert_allclose(res.sample("N_total"), lam[:, 0] + lam[:, 1], rtol=0, atol=1e-12)
    with pytest.raises(ModelError, match="no joint loads"):
        res.loads()
    with pytest.raises(ModelError, match="no quantity named 'N_mdial'.*'N_medial'"):
        res.sample("N_mdial")


@pytest.mark.skipif(not GAIT.is_dir(), reason="gait2354 data not present")
def test_gait_result_answers_in_the_same_words():
    from ocp_constraints.biomech.gait import run_inverse_dynamics

    r = run_inverse_dynamics(GAIT / "subject01_simbody.osim", GAIT / "subject01_walk1_ik.mot",
                             GAIT / "subject01_walk1_grf.mot", times=np.linspace(0.7, 0.8, 6))
    assert isinstance(r, Result) and r.success is True and r.status
    loads = r.loads()
    assert list(loads) == load_column_names(r.eqs)
    # Newton's third law across every two-body joint: the parent's share is minus the child's.
    by_joint: dict[str, list[str]] = {}
    for ch in r.eqs.load_channels:
        by_joint.setdefault(ch.joint, []).append(ch.prefix)
    pairs = [p for p in by_joint.values() if len(p) == 2]
    assert pairs
    for a, b in pairs:
        for k in ("F_x", "F_y", "F_z"):
            np.testing.assert_allclose(loads[f"{a}.{k}"], -loads[f"{b}.{k}"], rtol=0, atol=1e-8)
    # load_about: eq. (33) by hand, about the child's center of mass.
    a = pairs[0][1]
    body = a.split("@")[1]
    x_A = np.column_stack([r.sample(f"{body}.{c}") for c in "xyz"])
    F_hand, M_hand = _moved_by_hand(loads, a, x_A)
    F, M = r.load_about(a, r.model.bodies[body].com)
    np.testing.assert_allclose(M, M_hand, rtol=0, atol=1e-8)
    # Generalized forces answer by their loads.csv names.
    np.testing.assert_allclose(r.sample("knee_angle_r_moment"), r.generalized_force("knee_angle_r"), rtol=0, atol=0)
    with pytest.raises(ModelError, match="did you mean 'knee_angle_r_moment'"):
        r.sample("knee_angle_r_momnt")
