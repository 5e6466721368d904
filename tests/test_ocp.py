"""Direct-collocation optimal control: accuracy orders, loads, residuals, failures."""
from __future__ import annotations

import json

import numpy as np
import pytest

from ocp_constraints import build_scene
from ocp_constraints.cli.main import main
from ocp_constraints.errors import ModelError
from ocp_constraints.ocp.problem import OptimalControlProblem
from ocp_constraints.errors import OCPSolveError
from ocp_constraints.scenes.registry import build_task
from ocp_constraints.scenes.tasks import simulate_scene
from ocp_constraints.ocp.schemes import HermiteSimpson, Radau, Trapezoidal, scheme_from_name


@pytest.fixture(scope="module")
def free_pendulum():
    """The tilted pendulum's free motion over 1 s, from the core's forward simulation."""
    scene = build_scene("pendulum")
    return scene, simulate_scene(scene, 1.0)


def _free_motion_error(scene, reference, method) -> float:
    # No controls and no objective: the OCP is the DAE's boundary-value problem.
    ocp = OptimalControlProblem(scene.model, t_final=1.0)
    ocp.initial({"rod.psi": scene.coordinates["rod.psi"], "rod.psi_dot": 0.0})
    sol = ocp.solve(method)
    assert max(sol.residuals()) <= 1e-8
    return abs(sol.sample("rod.psi")[-1] - reference.sample("rod.psi")[-1])


@pytest.mark.parametrize("coarse, fine, min_ratio, max_error", [
    (Trapezoidal(10), Trapezoidal(20), 3.0, 2e-2),            # order 2: ratio 4
    (HermiteSimpson(10), HermiteSimpson(20), 12.0, 1e-5),     # order 4: ratio 16
    (Radau(10, degree=2), Radau(20, degree=2), 6.0, 2e-3),    # order 3: ratio 8
    (Radau(5, degree=3), Radau(10, degree=3), 20.0, 1e-4),    # order 5: ratio 32
])
def test_free_motion_reproduces_the_forward_simulation_at_the_schemes_order(free_pendulum, coarse, fine, min_ratio, max_error):
    scene, reference = free_pendulum
    e_coarse = _free_motion_error(scene, reference, coarse)
    e_fine = _free_motion_error(scene, reference, fine)
    assert e_fine < max_error
    assert e_coarse / e_fine >= min_ratio


@pytest.fixture(scope="module")
def swing_up():
    return build_task("pendulum", "swing_up")[1]


def test_swing_up_meets_bounds_boundary_conditions_and_keeps_constraints(swing_up):
    sol = swing_up.solve(Radau(30, degree=3))
    assert sol.success and sol.status == "Solve_Succeeded"
    position, velocity = sol.residuals()
    assert position <= 1e-8 and velocity <= 1e-8
    torque = sol.sample("motor")
    assert np.all(np.abs(torque) <= 20.0 + 1e-8)
    psi = sol.sample("rod.psi")
    assert psi[0] == pytest.approx(0.0, abs=1e-9) and psi[-1] == pytest.approx(np.pi, abs=1e-9)
    assert sol.sample("rod.psi_dot")[-1] == pytest.approx(0.0, abs=1e-9)
    # The objective is the integral of torque squared: check it by a separate quadrature
    # of the interpolated torque.
    t = np.linspace(0, 2, 4001)
    tau = sol.interpolate("motor", t)
    assert sol.objective == pytest.approx(np.trapezoid(tau**2, t), rel=1e-3)


def test_swing_up_objective_agrees_across_transcriptions(swing_up):
    radau = swing_up.solve(Radau(40, degree=3)).objective
    hs = swing_up.solve(HermiteSimpson(40)).objective
    assert radau == pytest.approx(hs, rel=1e-4)


def _pointwise_gap(problem, method) -> float:
    """Largest gap between the solution's multipliers and the forward dynamics' (the KKT solve
    of the state and inputs at each point), relative to the largest multiplier."""
    sol = problem.solve(method)
    eqs = problem.eqs
    kkt = np.array([np.asarray(eqs.forward_dynamics(q, u, t, w, [0.0])[1]).ravel()
                    for q, u, t, w in zip(sol.trajectory.q, sol.trajectory.u, sol.t, sol.inputs.T)])
    return np.abs(kkt - sol.lam.T).max() / np.abs(kkt).max()


def test_maximal_form_loads_agree_with_pointwise_dynamics_and_the_gap_shrinks(swing_up):
    # In maximal coordinates the Posa slacks let the NLP's multipliers differ from the
    # pointwise ones by the discretization error, which shrinks with the mesh.
    swing_up.coordinates = "maximal"
    try:
        gaps = [_pointwise_gap(swing_up, Radau(n, degree=3)) for n in (15, 30)]
    finally:
        swing_up.coordinates = "auto"
    assert gaps[1] < gaps[0] / 2
    assert gaps[1] < 1e-2


def test_joint_form_loads_are_the_pointwise_dynamics_on_any_mesh(swing_up):
    # In joint coordinates the hinge's multipliers follow from each point's own balance (paper
    # sec. 5): they equal the forward dynamics' at that state to round-off, on a coarse mesh too.
    assert swing_up.nlp_coordinates == "joint"
    assert _pointwise_gap(swing_up, Radau(15, degree=3)) < 1e-10


def test_second_solve_reuses_the_transcription(swing_up):
    first = swing_up.solve(Trapezoidal(20))
    solver = first.transcription._solver
    second = swing_up.solve(Trapezoidal(20))
    assert second.transcription is first.transcription
    assert second.transcription._solver is solver      # IPOPT's nlpsol object is not built again
    assert second.objective == pytest.approx(first.objective, rel=1e-9)


def test_infeasible_swing_up_raises_with_ipopt_status_and_keeps_last_iterate(tmp_path):
    _, problem = build_task("pendulum", "swing_up", {"max_torque": 0.1})
    with pytest.raises(OCPSolveError) as info:
        problem.solve(Trapezoidal(20), {"ipopt.max_iter": 200})
    assert "status" in str(info.value)
    assert info.value.solution.success is False
    assert np.all(np.isfinite(info.value.solution.X))
    code = main(["solve", "pendulum", "--scheme", "trapezoidal", "--intervals", "20", "--param", "max_torque=0.1",
                 "--out", str(tmp_path), "--no-plots"])
    assert code == 1
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success"] is False and summary["status"] != "Solve_Succeeded"
    assert (tmp_path / "trajectory.csv").exists() and (tmp_path / "loads.csv").exists()


def test_solve_command_writes_results_with_objective(tmp_path):
    assert main(["solve", "pendulum", "--intervals", "20", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success"] is True and summary["task"] == "swing_up"
    assert summary["objective"] > 0 and summary["solver"]["transcription"] == "radau3"
    header = (tmp_path / "loads.csv").read_text().splitlines()[0].split(",")
    assert {"hinge.v1.lambda", "hinge.w2.lambda", "hinge.F_x", "hinge.M_y", "hinge.power"} <= set(header)
    assert "motor" in (tmp_path / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert (tmp_path / "loads_hinge.png").exists()


def test_bad_transcription_and_problem_input_is_named():
    with pytest.raises(ModelError, match="unknown transcription 'euler'"):
        scheme_from_name("euler")
    with pytest.raises(ModelError, match="degree must be a whole number from 1 to 9"):
        Radau(10, degree=10)
    with pytest.raises(ModelError, match="mesh must be increasing"):
        Trapezoidal(mesh=(0.0, 0.6, 0.5, 1.0))
    # Radau(6, 20): degree 6 on 20 intervals, or the reverse? Only the interval count may be positional.
    with pytest.raises(TypeError, match="positional"):
        Radau(6, 20)
    _, problem = build_task("pendulum", "swing_up")
    with pytest.raises(ModelError, match="no quantity named 'rod.spin'"):
        problem.bound("rod.spin", -1, 1)
    # a rate: refused where it is written, with the path constraint to write instead (it used to pass until solve)
    with pytest.raises(ModelError, match=r"bound on 'rod.psi_dot': .* is a rate; .*subject_to\(problem.quantity\('rod.psi_dot'\), -3, 3"):
        problem.bound("rod.psi_dot", -3, 3)
    assert "rod.psi_dot" not in problem.bounds
    with pytest.raises(ModelError, match="lower 2.0 exceeds upper 1.0"):
        problem.bound("motor", 2.0, 1.0)
    with pytest.raises(ModelError, match="no constraint 'hinge.v9'"):
        problem.multiplier("hinge.v9")


def test_user_mesh_is_used():
    _, problem = build_task("pendulum", "swing_up")
    mesh = tuple(np.sort(np.r_[0.0, 1.0, np.linspace(0, 1, 31)[1:-1] ** 1.3]))
    sol = problem.solve(Radau(mesh=mesh, degree=2))
    assert sol.success
    assert np.allclose(sol.transcription.scheme.mesh_fractions * 2.0, sol.t[::2])


def test_free_final_time_minimum_time_swing_up_is_bang_bang(ocp_minimum_time_swing_up):
    # Minimum time with a bounded torque entering affinely: Pontryagin's principle makes the
    # torque sit on its bounds (bang-bang) except at switches.
    base, problem = ocp_minimum_time_swing_up
    problem.set_guess("rod.psi", lambda t: np.pi * t / 2 - np.sin(np.pi * t / 2))
    sol = problem.solve(Radau(30, degree=3))
    assert sol.success and 0.5 < sol.t_final < 2.0 and sol.objective == pytest.approx(sol.t_final)
    assert np.mean(np.abs(sol.sample("motor")) > 5.0 - 1e-3) > 0.8
    assert max(sol.residuals()) <= 1e-8
    with pytest.raises(ModelError, match="free final time"):
        base.minimize_final_time()


@pytest.mark.parametrize("method", [Radau(6, degree=3), Radau(5, degree=1), Radau(4, degree=6), HermiteSimpson(8), Trapezoidal(12)])
def test_reported_accelerations_satisfy_the_dynamics_at_every_point(method):
    # Radau's accelerations after t0 are not NLP variables but (sum_r C[r, j] u_r) / h:
    # the reported u' must be those, i.e. satisfy M u' = f + G^T lambda at every point.
    import casadi as ca

    _, problem = build_task("pendulum", "swing_up")
    sol = problem.solve(method)
    e = problem.eqs           # the bodies' equations, whatever coordinates the NLP was written in
    a, lam = ca.SX.sym("a", e.nu), ca.SX.sym("lam", e.nc)
    dynamics = ca.Function("dynamics", [e.q, e.u, e.t, e.inputs, a, lam], [e.mass_matrix @ a - e.forces - e.G.T @ lam])
    traj = sol.trajectory
    worst = max(float(np.abs(np.asarray(dynamics(traj.q[i], traj.u[i], sol.t[i], sol.inputs[:, i], traj.udot[i], traj.lam[i]))).max())
                for i in range(len(sol.t)))
    assert worst <= 1e-8 * max(1.0, float(np.abs(traj.lam).max()))


def test_warm_start_from_a_coarse_mesh_reaches_the_fine_optimum_in_fewer_iterations():
    # Mesh refinement: a Radau-3 N = 20 solution interpolated onto Hermite-Simpson N = 60.
    _, problem = build_task("pendulum", "swing_up")
    problem.coordinates = "maximal"       # the start checked below is the maximal form's NLP vector
    coarse = problem.solve(Radau(20, degree=3))
    cold = problem.solve(HermiteSimpson(60))
    warm = problem.solve(HermiteSimpson(60), warm_start=coarse)
    assert warm.success and warm.objective == pytest.approx(cold.objective, rel=1e-9)
    assert warm.iterations < cold.iterations
    # The start itself: states through the coarse polynomials, projected onto phi = 0
    # (which moves them by the coarse mesh's error, ~1e-4 here).
    tr = warm.transcription
    start = tr.guess_from(coarse)
    X = start[: tr.layout.nx * len(warm.t)].reshape(len(warm.t), -1)
    psi = problem.model.coordinate_names.index("rod.psi")
    assert np.abs(X[:, psi] - coarse.interpolate("rod.psi", warm.t)).max() <= 1e-3
    e = tr.eqs
    for i in range(len(warm.t)):
        _, _, phi, _, _ = e.constraint_functions(X[i, : e.nq], X[i, e.nq :], warm.t[i], warm.inputs[:, i])
        assert np.abs(np.asarray(phi)).max() <= 1e-10


def test_warm_start_from_another_model_is_an_error_naming_both():
    _, pendulum = build_task("pendulum", "swing_up")
    _, whirling = build_task("whirling", "spin_up")
    sol = pendulum.solve(Trapezoidal(10))
    with pytest.raises(ModelError, match="warm_start: the solution's model 'pendulum' has coordinates"):
        whirling.solve(Trapezoidal(10), warm_start=sol)
    with pytest.raises(ModelError, match="warm_start must be a solution from problem.solve.*got ndarray"):
        pendulum.solve(Trapezoidal(10), warm_start=sol.decision_vector)
