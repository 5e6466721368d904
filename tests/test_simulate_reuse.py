"""The fixed-cost paths of forward simulation (issue 14): buffered CasADi calls, integrators shared
between equal models, trajectories stored a segment at a time, projection with its drifts."""
import casadi as ca
import numpy as np

from ocp_constraints import SystemEquations, build_scene, consistent_state, simulate
from ocp_constraints.dynamics.simulate import SimulationOptions
from ocp_constraints.dynamics.trajectory import Trajectory
from ocp_constraints.mechanics.fast_eval import Buffered
from ocp_constraints.mechanics.state import project_with_drift


def test_buffered_call_gives_casadis_own_results_for_sparse_and_matrix_arguments():
    x, y = ca.SX.sym("x", 3), ca.SX.sym("y", 2, 2)
    s = ca.SX.sym("s")
    f = ca.Function("f", [x, y, s], [ca.sparsify(ca.vertcat(x[0] * s, 0, x[2] ** 2)), y @ y.T + s, ca.jacobian(ca.sin(x) * s, x)])
    args = (np.array([0.3, -1.2, 2.0]), np.array([[1.0, 2.0], [-3.0, 0.5]]), 1.7)
    expected = [np.asarray(o) for o in f(*args)]
    got = Buffered(f)(*args)
    assert np.array_equal(got[0], expected[0].ravel())       # a column vector comes back 1-D
    assert np.array_equal(got[1], expected[1])
    assert np.array_equal(got[2], expected[2])                 # sparse (diagonal) Jacobian, dense result
    again = Buffered(f)(np.zeros(3), np.eye(2), 0.0)           # the results are fresh arrays, not the buffer
    assert np.array_equal(got[1], expected[1]) and np.array_equal(again[1], np.eye(2))


def _run(params=None, t_final=0.5, dt=0.01):
    scene = build_scene("sliding_disk", params)
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    return eqs, simulate(eqs, q0, u0, t_final, SimulationOptions(dt=dt, rtol=1e-10, atol=1e-10, compiled="never"))


def test_the_same_scene_built_twice_shares_its_integrators_and_gives_the_same_trajectory():
    eqs1, a = _run()
    eqs2, b = _run()
    assert eqs1 is not eqs2
    assert list(eqs1._simulation_integrators.values())[0] is list(eqs2._simulation_integrators.values())[0]
    assert np.array_equal(a.q, b.q) and np.array_equal(a.lam, b.lam)
    eqs3, c = _run({"radius": 0.2}, dt=1e-3)          # another model: its own integrators
    assert list(eqs3._simulation_integrators.values())[0] is not list(eqs1._simulation_integrators.values())[0]
    # and its own physics: the paper's eq. (4), lambda = m R (theta'' cos theta - theta'^2 sin theta) + m g,
    # with theta'' by central differences of the sampled theta' (error ~ dt^2/6 theta, ~1e-4 N at dt = 1 ms)
    p = build_scene("sliding_disk", {"radius": 0.2}).model.parameters
    th, thd = c.sample("disk.theta"), c.sample("disk.theta_dot")
    thdd = np.gradient(thd, c.t)
    lam_eq4 = p["mass"] * p["radius"] * (thdd * np.cos(th) - thd**2 * np.sin(th)) + p["mass"] * p["gravity"]
    assert np.abs(c.sample("contact.n.lambda") - lam_eq4)[1:-1].max() < 1e-3 * p["mass"] * p["gravity"]


def test_trajectory_keeps_whole_samples_whether_added_one_at_a_time_or_by_segment():
    eqs, traj = _run(t_final=0.05)
    copy = Trajectory(eqs)
    for k in range(len(traj)):
        copy.append(traj.t[k], traj.q[k], traj.u[k], traj.udot[k], traj.lam[k], traj.inputs[k], traj.work[k],
                    0.0, 0.0, traj.applied_work[k])
    assert np.array_equal(copy.q, traj.q) and np.array_equal(copy.lam, traj.lam) and len(copy) == len(traj)
    copy._rows["t"].append(np.array([[1.0]]))         # an interruption after the first quantity of a sample
    copy.drop_incomplete_sample()
    assert len(copy) == len(traj) and copy.q.shape == traj.q.shape and np.array_equal(copy.t, traj.t)


def test_projection_reports_the_drift_it_removed_and_lands_on_the_constraints():
    scene = build_scene("sliding_disk")
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    q, u = q0 + 1e-6 * np.arange(1, eqs.nq + 1), u0 - 1e-6 * np.arange(1, eqs.nu + 1)
    _, _, phi, pi, _ = eqs.constraint_functions(q, u, 0.0, np.zeros(0))
    q1, u1, drift_q, drift_u = project_with_drift(eqs, q, u, 0.0)
    assert drift_q == float(np.abs(np.asarray(phi)).max()) and drift_u == float(np.abs(np.asarray(pi)).max())
    _, _, phi1, pi1, _ = eqs.constraint_functions(q1, u1, 0.0, np.zeros(0))
    assert np.abs(np.asarray(phi1)).max() < 1e-15 and np.abs(np.asarray(pi1)).max() < 1e-14
    assert np.abs(q1 - q).max() < 1e-5 and np.abs(u1 - u).max() < 1e-4   # nearby, not elsewhere
