"""The times at which a problem's expressions kink or jump (ocp/time_breakpoints.py) become mesh points of the
refinement's first mesh.

Reference for the accuracy check: Pontryagin's two-point problem of a block on a rail tracking a sampled reference
(min int w (x - r)^2 + u^2, r linear between samples at 30 Hz), solved by SciPy's solve_bvp at tol 1e-8 (it agrees
with tol 1e-10 to 4e-13 m in x and 3e-12 m/s in v), a method independent of the library.
"""
import time

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_bvp

import ocp_constraints as oc
from ocp_constraints.ocp.time_breakpoints import breakpoint_times

T, M, W = 1.0, 1.0, 1e4
SAMPLES = np.linspace(0.0, T, 31)                 # 30 Hz: never a mesh point of halved uniform meshes
VALUES = 0.1 * np.sin(2 * np.pi * SAMPLES)


def test_breakpoints_are_read_from_the_expressions_operations():
    t, q = ca.SX.sym("t"), ca.SX.sym("q", 2)
    found = breakpoint_times([ca.fabs(2 * t - 1) + ca.if_else(t < 0.3, q[0], q[1]) + ca.fmin(t, 0.7) + q[0] * t], t)
    assert np.allclose(found, [0.3, 0.5, 0.7], atol=1e-12)
    assert np.allclose(breakpoint_times([ca.pw_lin(t, ca.DM(SAMPLES[:4]), ca.DM(VALUES[:4]))], t), SAMPLES[1:3])
    assert np.allclose(breakpoint_times([ca.if_else(2 * t + 1 < 1.6, q[0], q[1] / 3)], t), [0.3])
    # smooth in t, or switching on a state: nothing
    assert breakpoint_times([ca.sin(t) * q[0] + q[1] ** 2, ca.if_else(q[0] < 0.3, t, 0)], t).size == 0


def _block_tracking_samples() -> oc.OptimalControlProblem:
    model = oc.Model("block", gravity=(0.0, -9.81, 0.0))
    block = model.add_body("block", M, np.diag([0.01, 0.01, 0.01]), rotation="321")
    E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])
    model.add_constraint("rail.v2", ca.dot(E2, block.com.v), joint="rail", position=block.com.position[1])
    model.add_constraint("rail.v3", ca.dot(E3, block.com.v), joint="rail", position=block.com.position[2])
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"rail.w{k + 1}", ca.dot(E, block.omega), joint="rail")
    model.add_force("push", block.com, ca.vertcat(model.add_input("u"), 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=T)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
    ocp.track("block.x", lambda t: ca.pw_lin(t, ca.DM(SAMPLES), ca.DM(VALUES)), weight=W)
    ocp.minimize_effort(["u"])
    return ocp


@pytest.fixture(scope="module")
def pontryagin():
    def rhs(t, y):
        x, v, p1, p2 = y
        return np.vstack([v, -p2 / (2 * M * M), -2 * W * (x - np.interp(t, SAMPLES, VALUES)), -p1])

    mesh = np.linspace(0.0, T, 201)
    sol = solve_bvp(rhs, lambda a, b: np.array([a[0], a[1], b[2], b[3]]), mesh, np.zeros((4, mesh.size)), tol=1e-8,
                    max_nodes=100000)
    assert sol.status == 0
    return sol.sol


def test_a_sampled_reference_is_met_with_a_mesh_point_at_every_sample(pontryagin):
    sol = _block_tracking_samples().solve(tolerance=1e-6)
    r = sol.mesh_refinement
    assert r["met"], r["message"]
    mesh = np.asarray(r["mesh"]) * T
    assert all(np.abs(mesh - s).min() < 1e-12 for s in SAMPLES[1:-1])
    t = np.asarray(sol.t)
    for name, row in (("block.x", 0), ("block.vbar_x", 1)):
        assert np.abs(np.asarray(sol.sample(name)) - pontryagin(t)[row]).max() <= r["estimate"]["states"], name
