"""The times at which a problem's expressions kink or jump (ocp/time_breakpoints.py) become mesh points of the
refinement's first mesh.

Reference for the accuracy check: Pontryagin's two-point problem of a block on a rail tracking a sampled reference
(min int w (x - r)^2 + u^2, r linear between samples at 30 Hz), solved by SciPy's solve_bvp
(:mod:`ocp_constraints.bench.sampled_tracking`), a method independent of the library.
"""
import casadi as ca
import numpy as np
import pytest

from ocp_constraints.bench.sampled_tracking import SAMPLES, T, VALUES, pontryagin_solution, sampled_tracking_block
from ocp_constraints.ocp.time_breakpoints import breakpoint_times


def test_breakpoints_are_read_from_the_expressions_operations():
    t, q = ca.SX.sym("t"), ca.SX.sym("q", 2)
    found = breakpoint_times([ca.fabs(2 * t - 1) + ca.if_else(t < 0.3, q[0], q[1]) + ca.fmin(t, 0.7) + q[0] * t], t)
    assert np.allclose(found, [0.3, 0.5, 0.7], atol=1e-12)
    assert np.allclose(breakpoint_times([ca.pw_lin(t, ca.DM(SAMPLES[:4]), ca.DM(VALUES[:4]))], t), SAMPLES[1:3])
    assert np.allclose(breakpoint_times([ca.if_else(2 * t + 1 < 1.6, q[0], q[1] / 3)], t), [0.3])
    # smooth in t, or switching on a state: nothing
    assert breakpoint_times([ca.sin(t) * q[0] + q[1] ** 2, ca.if_else(q[0] < 0.3, t, 0)], t).size == 0


@pytest.fixture(scope="module")
def pontryagin():
    return pontryagin_solution()


def test_a_sampled_reference_is_met_with_a_mesh_point_at_every_sample(pontryagin):
    sol = sampled_tracking_block().solve(tolerance=1e-6)
    r = sol.mesh_refinement
    assert r["met"], r["message"]
    mesh = np.asarray(r["mesh"]) * T
    assert all(np.abs(mesh - s).min() < 1e-12 for s in SAMPLES[1:-1])
    t = np.asarray(sol.t)
    for name, row in (("block.x", 0), ("block.vbar_x", 1)):
        assert np.abs(np.asarray(sol.sample(name)) - pontryagin(t)[row]).max() <= r["estimate"]["states"], name
