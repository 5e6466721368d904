"""A continuous bounded quantity (a speed limit: a path constraint of the states alone) crosses from one
bound to the other along a free arc, two junctions; only inputs and multipliers jump (ocp/switch_detection.py,
issue 19). Found by scripts/refinement_robustness.py on examples/robot_arm_urdf.py: the UR5 elbow's speed
limit, taken as a jump, put a 5.6 rad/s "effect" into the states' estimate at every mesh."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocp_constraints import Model, OptimalControlProblem, Radau, joints
from ocp_constraints.ocp.switch_detection import ACTIVE, TIGHT, activity, bounded_quantities, locate


def test_a_continuous_quantity_between_its_bounds_has_two_junctions_where_it_leaves_and_reaches_them():
    # v = clip(3 cos(pi t), -1, 1): at +1 until acos(1/3)/pi, free, at -1 from acos(-1/3)/pi (closed form).
    t = np.linspace(0.02, 0.98, 25)
    v = np.clip(3.0 * np.cos(math.pi * t), -1.0, 1.0)
    s, eps = activity(v, -1.0, 1.0)
    leave, reach = math.acos(1 / 3) / math.pi, math.acos(-1 / 3) / math.pi
    found = locate(t, v, s, -1.0, 1.0, eps, jumps=False)
    assert [k for _, k, _, _ in found] == ["junction", "junction"]
    spacing = t[1] - t[0]
    assert abs(found[0][0] - leave) < spacing and abs(found[1][0] - reach) < spacing
    # The same values of an input are one jump, as before (a smeared bang-bang between the bounds).
    [(_, kind, _, _)] = locate(t, v, s, -1.0, 1.0, eps)
    assert kind == "bang-bang"


def test_neighbouring_points_at_opposite_bounds_of_a_continuous_quantity_are_a_junction():
    t, v = np.array([0.1, 0.2, 0.3, 0.4]), np.array([1.0, 1.0, -1.0, -1.0])
    s, eps = activity(v, -1.0, 1.0)
    assert [k for _, k, _, _ in locate(t, v, s, -1.0, 1.0, eps, jumps=False)] == ["junction"]
    assert [k for _, k, _, _ in locate(t, v, s, -1.0, 1.0, eps)] == ["bang-bang"]


def test_path_constraints_of_the_states_alone_are_continuous_those_of_inputs_or_multipliers_are_not():
    model = Model("block", gravity=(0.0, 0.0, -9.81))
    block = model.add_body("block", 1.0, 0.1 * np.eye(3), rotation="321")
    joints.prismatic(model, "slider", block.point("centre", (0.0, 0.0, 0.0)), axis=(1, 0, 0), anchor=(0.0, 0.0, 0.0))
    model.add_force("push", block.com, ca.vertcat(model.add_input("F"), 0, 0))
    problem = OptimalControlProblem(model, t_final=1.0)
    problem.initial({"block.x": 0.0, "block.x_dot": 0.0})
    problem.final({"block.x": 0.5, "block.x_dot": 0.0})
    problem.minimize_effort()
    problem.bound("F", -10.0, 10.0)
    problem.subject_to(problem.quantity("block.vbar_x"), -0.7, 0.7, "speed limit")
    problem.subject_to(problem.quantity("F") ** 2, 0.0, 50.0, "push squared")
    problem.subject_to(problem.joint_force("slider")[2], -50.0, 50.0, "rail's lift")
    sol = problem.solve(Radau(4, degree=3), progress=False)
    flags = {name: continuous for name, _, _, _, _, continuous in bounded_quantities(sol)}
    assert flags == {"F": False, "speed limit": True, "push squared": False, "rail's lift": False}


def test_an_input_crossing_between_its_bounds_over_many_intervals_is_an_arc_not_a_jump():
    """Minimum effort under a force limit: F = clip(3 cos(pi t), -1, 1) leaves +1 at acos(1/3)/pi and reaches -1
    at acos(-1/3)/pi along a free arc (closed form); over several mesh intervals that is two junctions, while
    the same values inside two intervals (or within JUMP_SPAN of the horizon) are a smeared jump."""
    from ocp_constraints.ocp.switch_detection import JUMP_SPAN

    t = np.linspace(0.02, 0.98, 25)
    v = np.clip(3.0 * np.cos(math.pi * t), -1.0, 1.0)
    s, eps = activity(v, -1.0, 1.0)
    many = np.floor(t * 20).astype(int)                       # twenty intervals: the free run spans four
    found = locate(t, v, s, -1.0, 1.0, eps, intervals=many)
    assert [k for _, k, _, _ in found] == ["junction", "junction"]
    leave, reach = math.acos(1 / 3) / math.pi, math.acos(-1 / 3) / math.pi
    assert abs(found[0][0] - leave) < t[1] - t[0] and abs(found[1][0] - reach) < t[1] - t[0]
    two = np.where(t < 0.5, 0, 1)                             # two intervals: a jump smeared by the NLP
    assert [k for _, k, _, _ in locate(t, v, s, -1.0, 1.0, eps, intervals=two)] == ["bang-bang"]
    short = 0.3 + (t - 0.3) * (0.5 * JUMP_SPAN / 0.96)          # the run within JUMP_SPAN of the horizon
    assert [k for _, k, _, _ in locate(short, v, s, -1.0, 1.0, eps, intervals=many)] == ["bang-bang"]


def test_an_inputs_junction_is_found_where_its_line_meets_the_bound_through_the_points_counted_active():
    """F = min(U, a - b t) at points 0.01 apart: the first two points past the junction (t1 = 0.3) are within the
    activity threshold of U, so they count as active. The line through the free points meets U at t1 exactly;
    only ``through_active`` may put the junction there, behind the last "active" point, with
    the two points around it as its bracket. Without it the junction is clamped to the last "active" point, two
    points late."""
    U, b, t1 = 5.4, 0.5, 0.3
    t = np.round(np.arange(0.0, 1.0001, 0.01), 12)
    v = np.minimum(U, U - b * (t - t1))
    s, eps = activity(v, -np.inf, U)
    assert s[31] == 1 and s[32] == 1 and s[33] == 0          # 0.31, 0.32 within the threshold: "active"
    [(at, kind, i, j)] = locate(t, v, s, -np.inf, U, eps, jumps=True, through_active=True)
    assert kind == "junction" and abs(at - t1) < 1e-12 and t[i] <= at <= t[j] and j == i + 1
    [(late, _, _, _)] = locate(t, v, s, -np.inf, U, eps, jumps=True)
    assert late >= 0.32


def test_a_tangential_junction_is_found_where_the_square_root_of_the_distance_reaches_the_bound():
    """A speed limit reached tangentially, v = VMAX - c (t1 - t)^2 up to t1 = 0.3, then held: the distance from
    the bound is quadratic in time, so the line through the two nearest free points, drawn for the distance,
    reaches the bound early (between t = 0.33 and t1), while the one drawn for its square root lies on the third
    point too and reaches it at t1 exactly, behind the points within the activity threshold. A slack linear in
    time (an input leaving its bound) is still found by the distance's own line."""
    VMAX, c, t1 = 0.65, 2.0, 0.3
    t = np.round(np.arange(0.0, 1.0001, 0.01), 12)
    v = np.where(t < t1, VMAX - c * (t1 - t) ** 2, VMAX)
    s, eps = activity(v, -np.inf, VMAX)
    assert s[28] == 1 and s[27] == 0                        # 0.28, 0.29 within the threshold: "active" early
    [(at, kind, i, j)] = locate(t, v, s, -np.inf, VMAX, eps, jumps=False, through_active=True)
    assert kind == "junction" and abs(at - t1) < 1e-9 and t[i] <= at <= t[j]
    d = VMAX - v[[27, 26]]                                  # the distance's own line, as drawn before
    assert 0.27 + d[0] / (d[1] - d[0]) * 0.01 < t1 - 0.01
    w = np.minimum(VMAX, VMAX - 0.5 * (t - t1))            # a kink: the distance linear in time
    s, eps = activity(w, -np.inf, VMAX)
    [(at, _, _, _)] = locate(t, w, s, -np.inf, VMAX, eps, jumps=True, through_active=True)
    assert abs(at - t1) < 1e-12


def test_a_position_bound_reached_with_zero_speed_and_acceleration_is_found_where_the_cube_root_reaches_it():
    """Bryson and Denham's wall (Bryson and Ho sec. 3.11): x = l (1 - (1 - t / (3 l))^3) reaches x = l = 1/9 at
    t = 3 l = 1/3 with zero speed and acceleration, its distance from the wall cubic in time. Its points within
    the activity threshold (2e-3 of the scale 1) start at t = 0.25, and the lines drawn for the distance and for
    its square root from the free points before them reach the wall at 0.268 and 0.301 (the library located
    0.3033 on Bryson-Denham's solution); the cube root's line lies on the third point too and reaches it at 1/3."""
    wall = 1 / 9
    t = np.round(np.arange(0.0, 0.5001, 0.01), 12)
    x = np.where(t < 3 * wall, wall * (1 - np.clip(1 - t / (3 * wall), 0, None) ** 3), wall)
    s, eps = activity(x, -1.0, wall)
    assert s[25] == 1 and s[24] == 0
    [(at, kind, i, j)] = locate(t, x, s, -1.0, wall, eps, jumps=False, through_active=True)
    assert kind == "junction" and abs(at - 3 * wall) < 1e-9 and t[i] <= at <= t[j]


def test_a_position_bound_approached_over_the_activity_threshold_is_found_through_the_approachs_own_points():
    """A position bound reached with zero speed whose approach is not a pure cube: the distance
    d = 1.7 (t1 - t)^3 (1 + 20 (t1 - t)), points 5 ms apart, held at 1.5e-10 past t1 (as IPOPT holds it). Within
    the activity threshold (2e-3 of the scale, 3.1e-3 rad here) the approach counts as active for ~0.09 s
    before t1, and the cube root's line through the free points beyond reaches the bound 17 ms early; drawn
    through the approach's own points still more than ``tight`` off the bound (TIGHT / ACTIVE of the threshold), it
    is found within 2.5 ms (a fifth newcomer's arm angle bound: 4.5 ms late before, an interval past the kink,
    0.1 ms after; results/bench/refinement_newcomer5.md)."""
    bound, t1 = -1.55, 1.2317
    t = np.round(np.arange(1.0, 1.6001, 0.005), 12)
    distance = np.where(t < t1, 1.7 * (t1 - t) ** 3 * (1 + 20 * (t1 - t)), -1.5e-10)
    v = bound - distance
    s, eps = activity(v, -np.inf, bound)
    assert s[t.searchsorted(1.15)] == 1                     # "active" 80 ms before the junction
    [(far, _, _, _)] = locate(t, v, s, -np.inf, bound, eps, jumps=False, through_active=True)
    [(at, kind, i, j)] = locate(t, v, s, -np.inf, bound, eps, jumps=False, through_active=True,
                                tight=eps * TIGHT / ACTIVE)
    assert abs(far - t1) > 0.01
    assert kind == "junction" and abs(at - t1) < 2.5e-3 and t[i] <= at <= t[j]


def test_an_input_with_an_effort_term_crosses_between_its_bounds_as_two_junctions_not_a_jump():
    """Pontryagin: where the integrand is strictly convex in an input, the optimal input minimizes a Hamiltonian
    strictly convex in it and follows the costates continuously, so it cannot jump from one bound to the other
    (a sixth newcomer's steep tracking pendulum: read as a jump, its window hid a multipliers' error 3.3x the
    estimate). The minimum-time block with 0.01 of effort on Radau 3 x 10 goes from F = 2 to F = -1 across one free
    point: before, one jump; now a junction on each side of that point. Without the effort term, still a jump."""
    from ocp_constraints.ocp.switch_detection import detect_switches, penalized_inputs
    from test_mesh_refinement_switches import _block

    hard = _block()
    soft = _block()
    soft.minimize_effort(["F"], weight=0.01)
    sol = soft.solve(Radau(10, degree=3))
    assert penalized_inputs(sol) == {"F"}
    found = detect_switches(sol)
    assert [w.kind for w in found] == ["junction", "junction"]
    F, t = np.asarray(sol.sample("F")), sol.t / sol.t_final
    last_up, first_low = int(np.flatnonzero(F > 2.0 - 1e-6)[-1]), int(np.flatnonzero(F < -1.0 + 1e-6)[0])
    assert first_low == last_up + 2           # one free point between the bounds
    assert t[last_up] <= found[0].fraction <= t[last_up + 1] <= found[1].fraction <= t[first_low]
    bang = hard.solve(Radau(10, degree=3))
    assert penalized_inputs(bang) == set() and [w.kind for w in detect_switches(bang)] == ["bang-bang"]
