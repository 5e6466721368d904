"""Inputs and multipliers between the points (ocp/interpolation.py, OCPSolution.interpolate).

A Radau interval's start is the previous interval's last collocation point. An input that jumps there (a
bang-bang switch on a mesh point) must be read from the interval's own points after it; a smooth one keeps the
start, whose value is the most accurate of all.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.interpolation import jumps_at_starts

MASS, LENGTH, T_FINAL, TAU_MAX = 1.0, 1.0, 2.0, 1.0
INERTIA = MASS * LENGTH**2 / 3          # a rod about its end


def _rod_turned_as_far_as_possible() -> oc.OptimalControlProblem:
    """A rod hinged at its end, no gravity, |motor| <= 1 N m, from rest to rest turned as far as it goes in 2 s
    (a Mayer objective): the motor is +1 then -1, switching at T/2 (Pontryagin; the problem is symmetric)."""
    model = oc.Model("rod", gravity=(0.0, 0.0, 0.0))
    rod = model.add_body("rod", MASS, MASS * LENGTH**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, LENGTH / 2, 0.0]), axis=(0, 0, 1))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("tau")))
    ocp = oc.OptimalControlProblem(model, t_final=T_FINAL)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi_dot": 0.0})
    ocp.bound("tau", -TAU_MAX, TAU_MAX)
    ocp.minimize_terminal(-ocp.quantity("rod.psi"))
    return ocp


@pytest.fixture(scope="module")
def bang_bang_rod():
    return _rod_turned_as_far_as_possible().solve(oc.Radau(10, degree=5))


def test_a_jump_on_a_mesh_point_is_read_from_each_side_own_points(bang_bang_rod):
    """The switch at the mesh point 1 s: after it the motor is -1 and the hinge carries the rod's centre
    (r = L/2) at r alpha = -3/2 m/s^2 tangentially and r omega^2 inward, omega = 3 (2 - t) rad/s. Through the
    interval's start (+1, the last point before the switch) the motor was up to 1.88 N m off and the hinge
    force 12% of its size; now 3e-8 N m and 6e-6."""
    sol = bang_bang_rod
    assert sol.success
    t = np.linspace(1.0005, 1.2, 40)
    assert np.abs(sol.interpolate("tau", t) + TAU_MAX).max() < 1e-6
    r, omega, alpha = LENGTH / 2, 3.0 * (T_FINAL - t), -3.0
    exact = MASS * np.hypot(r * alpha, r * omega**2)
    hinge = np.sqrt(sum(sol.interpolate(f"hinge.v{i}.lambda", t) ** 2 for i in (1, 2, 3)))
    assert np.abs(hinge - exact).max() < 1e-4 * exact.max()
    before = np.linspace(0.8005, 1.0, 40)       # the interval the jump closes keeps its start and its end: +1
    assert np.abs(sol.interpolate("tau", before) - TAU_MAX).max() < 1e-6


def test_only_the_interval_after_the_switch_is_read_from_its_own_points(bang_bang_rod):
    """The motor jumps at the start of the sixth of ten intervals and nowhere else; a smooth multiplier
    (the swing-up's, below) jumps nowhere."""
    sol = bang_bang_rod
    assert np.flatnonzero(jumps_at_starts(sol.transcription, sol.sample("tau"))).tolist() == [5]


def test_a_smooth_multiplier_keeps_the_polynomial_through_the_interval_start():
    """The same rod turned 2 rad, rest to rest, at least effort: the motor is I * 6 * 2 / T^2 * (1 - 2 t / T) = 1 - t
    N m (a cubic angle), which Radau 5 holds exactly. Nothing jumps, and interpolate() is the polynomial through every
    point of each interval, start included (the most accurate reading of a smooth quantity)."""
    ocp = _rod_turned_as_far_as_possible()
    ocp.final({"rod.psi": 2.0, "rod.psi_dot": 0.0})
    ocp.bound("tau", -10.0, 10.0)       # the motor's 1 N m would be touched at both ends, held inside by IPOPT's barrier
    ocp.minimize_effort(["tau"])
    sol = ocp.solve(oc.Radau(10, degree=5))
    t = np.linspace(0.0, T_FINAL, 97)
    assert np.abs(sol.interpolate("tau", t) - (1.0 - t)).max() < 1e-6
    for name in ("tau", "hinge.v1.lambda", "hinge.v2.lambda"):
        assert not jumps_at_starts(sol.transcription, sol.sample(name)).any()
        assert np.array_equal(sol.interpolate(name, t), sol.polynomial(name, t))
