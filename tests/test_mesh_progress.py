"""The stall rule of mesh refinement (ocp/mesh_progress.py) on refinement histories of the suite's problems.

The histories are the measured ones written in the README and in the module (points, largest estimate per
refinement): the four-bar at 1e-4, which refinement did not converge on, must stop; the walker's small steps at
switches, which met 1e-4 after one flat step, and the swing-up's and acrobot's converging steps must go on.
"""
from ocp_constraints.ocp.mesh_progress import STALL_GROWTH, stall_message


def _history(*steps):
    return [{"points": p, "estimate": {"states": e, "multipliers": e / 5}, "resolved": True,
             "worst": {"states": "crank.omega_z", "multipliers": "O.v1.lambda"}} for p, e in steps]


def test_the_four_bar_stops_when_doubling_the_points_cuts_its_estimate_only_1_4x():
    h = _history((31, 3.25), (281, 0.356), (883, 0.0151))
    assert stall_message(h, 1e-4) is None                       # 3.1x the points, 24x lower: going on
    msg = stall_message(_history((31, 3.25), (281, 0.356), (883, 0.0151), (1709, 0.0108)), 1e-4)
    assert msg is not None
    assert "1.9x (883 -> 1709 points)" in msg and "1.4x" in msg and "crank.omega_z" in msg and "1e-04" in msg


def test_small_steps_at_switches_and_converging_steps_go_on():
    # the walker's first two estimates are not recorded (README: 10x31 -> 20x141 -> ...); any that fall fast will do
    walker = _history((31, 1e-1), (141, 2e-3), (246, 3.4e-4), (302, 3.5e-4), (316, 1.8e-4), (323, 6.4e-5))
    assert all(stall_message(walker[:k], 1e-4) is None for k in range(2, 7))        # 1.02-1.23x the points
    acrobot = _history((31, 3.0), (281, 0.46), (820, 5.2e-5))
    swing_up = _history((31, 1e-2), (141, 5.7e-8))
    assert stall_message(acrobot, 1e-4) is None and stall_message(swing_up, 1e-6) is None


def test_the_first_refinement_is_not_judged():
    disk = _history((31, 0.14), (71, 0.067))       # the rolling disk at 1e-3: 2.3x the points, 2.1x lower; met next
    assert stall_message(disk, 1e-3) is None


def test_a_step_is_judged_from_the_growth_threshold_and_only_between_resolved_solutions():
    at = _history((31, 1.0), (100, 1e-3), (100 * STALL_GROWTH, 1e-3 / (STALL_GROWTH * 0.99)))
    assert stall_message(at, 1e-6) is not None                   # grew 1.5x, fell slightly less
    below = _history((31, 1.0), (100, 1e-3), (100 * STALL_GROWTH - 1, 1e-3))
    assert stall_message(below, 1e-6) is None                    # grew less than the threshold: not judged
    unresolved = _history((16, 4.0), (31, 3.25), (281, 3.0))
    unresolved[1]["resolved"] = False
    assert stall_message(unresolved, 1e-4) is None               # the guard's uniform step, not a refinement
