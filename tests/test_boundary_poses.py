"""ambiguous_boundary_poses: end values that leave a quaternion's sign free, so that two mirrored poses meet them.

The two-link planar arm of tests/test_refinement_user_problems.py (the seventh newcomer's URDF arm, its ARM_URDF),
joints about E3, so link k's quaternion is (cos a_k/2, 0, 0, sin a_k/2) with a_k
its absolute angle (a_1 = theta1, a_2 = theta1 + theta2). Fixing only cos(a_2/2) leaves a_2 and -a_2: link2.qz is
+sin(a_2/2) or -sin(a_2/2), values computed here from the angles alone.
"""
import re

import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.boundary_poses import ambiguous_boundary_poses
from test_refinement_user_problems import ARM_URDF

START = np.array([-np.pi / 2, 0.0])
THETA1, THETA2 = np.pi / 4, np.pi / 3       # the end asked for (shoulder, elbow), rad


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    pytest.importorskip("yourdfpy", reason="the URDF parser is the optional extra 'urdf'")
    path = tmp_path_factory.mktemp("arm") / "arm2.urdf"
    path.write_text(ARM_URDF)
    return oc.load_urdf(str(path), base="ground", gravity=(0.0, -9.81, 0.0))


def _arm(robot, guess: bool = False):
    """The arm from hanging to (THETA1, THETA2); the final end fixing link1 fully and link2 by cos(a_2/2) alone."""
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
    robot.set_boundary(problem, "initial", START)
    a1, a2 = THETA1, THETA1 + THETA2
    problem.final({"link1.qw": np.cos(a1 / 2), "link1.qz": np.sin(a1 / 2), "link2.qw": np.cos(a2 / 2),
                   "link1.omega_z": 0.0, "link2.omega_z": 0.0})
    if guess:
        end = np.array([THETA1, THETA2])
        robot.set_guess(problem, lambda t: START + (end - START) * np.clip(np.asarray(t, float), 0, 1)[:, None])
    return problem


def test_a_final_end_fixing_one_quaternion_parameter_of_the_elbow_link_names_its_mirror_with_both_signs(robot):
    messages = ambiguous_boundary_poses(_arm(robot))
    assert len(messages) == 1                   # the initial end (set_boundary) is determined
    message = messages[0]
    assert message.startswith("The final values") and "Body 'link2' (link2.qw fixed)" in message
    assert "link1" not in message.replace("link1.", "")      # link1 is fully fixed: not named as a body
    assert "fix link2.qz too (its sign chooses the pose)" in message
    values = sorted(float(v) for v in re.search(r"link2\.qz = ([+-][\d.]+) or ([+-][\d.]+)", message).groups())
    a2 = THETA1 + THETA2                        # a_2 or -a_2: sin(a_2/2) with either sign
    assert values == pytest.approx([-np.sin(a2 / 2), np.sin(a2 / 2)], abs=1e-3)


def test_the_pose_of_the_guess_is_the_first_one_offered(robot):
    """With a guess at the intended end (elbow at +THETA2), its sign of link2.qz is the one the message suggests."""
    message = ambiguous_boundary_poses(_arm(robot, guess=True))[0]
    suggested = float(re.search(r"problem\.final\(\{'link2\.qz': ([-\d.e]+)\}\)", message).group(1))
    assert suggested == pytest.approx(np.sin((THETA1 + THETA2) / 2), abs=1e-6)


def test_an_end_fixing_both_parameters_of_every_quaternion_as_set_boundary_does_is_not_ambiguous(robot):
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
    robot.set_boundary(problem, "initial", START)
    names = robot.set_boundary(problem, "final", np.array([THETA1, THETA2]))
    assert {"link1.qw", "link1.qz", "link2.qw", "link2.qz"} <= set(names)
    assert ambiguous_boundary_poses(problem) == []


def test_a_quaternion_reached_as_q_from_one_start_and_as_minus_q_from_another_is_one_rotation(robot):
    """link2 fixed through its center of mass (the elbow is where link1 puts it): one rotation. A guess on the other
    sheet (-q) ends there at -q, the consistent configuration at +q; parameters differ, rotations do not."""
    a1, a2 = THETA1, THETA1 + THETA2
    com = 0.5 * np.array([np.cos(a1), np.sin(a1)]) + 0.2 * np.array([np.cos(a2), np.sin(a2)])
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
    problem.final({"link1.qw": np.cos(a1 / 2), "link1.qz": np.sin(a1 / 2), "link2.x": com[0], "link2.y": com[1]})
    guess = robot.coordinates(np.array([THETA1, THETA2]))
    guess["link2.qw"], guess["link2.qz"] = -np.cos(a2 / 2), -np.sin(a2 / 2)
    for name, value in guess.items():
        problem.set_guess(name, lambda t, value=value: np.full(np.shape(t), value))
    assert ambiguous_boundary_poses(problem) == []


def test_a_pendulum_in_euler_angles_with_its_final_angle_fixed_is_not_ambiguous():
    model = oc.Model("pendulum")
    rod = model.add_body("rod", 1.0, np.diag([1 / 12, 1e-4, 1 / 12]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", (0.0, 0.5, 0.0)), axis=(0, 0, 1))
    problem = oc.OptimalControlProblem(model, t_final=1.0)
    problem.initial({"rod.psi": 0.0, "rod.omega_z": 0.0})
    problem.final({"rod.psi": 0.8})
    assert ambiguous_boundary_poses(problem) == []


def test_no_values_fixed_at_either_end_is_not_ambiguous(robot):
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
    assert ambiguous_boundary_poses(problem) == []
    problem.final({"link1.omega_z": 0.0, "link2.omega_z": 0.0})      # speeds only: still no coordinate fixed
    assert ambiguous_boundary_poses(problem) == []


def test_solve_warns_of_a_mirrored_final_pose_before_ipopt_starts(robot):
    """The check runs in ``solve``'s own checks (``check_problem``): the user sees an ``AmbiguousPoseWarning`` naming
    the body, whatever IPOPT then does; with both parameters fixed there is no warning."""
    import warnings

    from ocp_constraints.ocp.diagnostics import check_problem

    method = oc.Radau(mesh=tuple(np.linspace(0.0, 1.0, 5)), degrees=(3,) * 4)
    with pytest.warns(oc.AmbiguousPoseWarning, match=r"Body 'link2' \(link2.qw fixed\)"):
        check_problem(_arm(robot), method)
    problem = _arm(robot)
    robot.set_boundary(problem, "final", np.array([THETA1, THETA2]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", oc.AmbiguousPoseWarning)
        check_problem(problem, method)
