"""A quaternion body's boundary values in an optimal-control problem: the pre-solve check names what a
newcomer gets wrong, instead of a numpy 'SVD did not converge', a silently rescaled quaternion, or IPOPT
running to its iteration limit (issue 13: problems not in the suite)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.diagnostics import check_problem

TARGET = (0.8686198214082874, 0.35438937171419277, 0.2968801535759501, 0.1782412788480126)   # unit


def _spherical_pendulum():
    """A rod on a hand-written ball joint at its top end, three torques, rest to rest."""
    model = oc.Model("sph_q", gravity=(0.0, 0.0, -9.81))
    bob = model.add_body("bob", 1.0, np.diag([1 / 12, 1 / 12, 0.01]), rotation="quaternion")
    P = bob.point("P", (0.0, 0.0, 0.5))
    for k in range(3):
        model.add_constraint(f"ball.v{k + 1}", ca.dot(ca.DM.eye(3)[:, k], P.v), joint="ball", position=P.position[k])
    model.add_torque("motor", bob, ca.vertcat(*[model.add_input(f"t{c}") for c in "xyz"]))
    ocp = oc.OptimalControlProblem(model, t_final=2.0)
    rest = {f"bob.omega_{c}": 0.0 for c in "xyz"}
    ocp.initial(rest)
    ocp.final(rest)
    ocp.minimize_effort()
    return ocp


def test_no_initial_orientation_of_a_quaternion_body_is_named_not_a_numpy_error():
    ocp = _spherical_pendulum()
    with pytest.raises(oc.ModelError, match=r"initial values of .*bob\.q.* are not determined.*unit quaternion"):
        check_problem(ocp, oc.Radau(4, degree=3))


def test_a_quaternion_whose_length_no_initial_value_fixes_is_named():
    """qx = qy = qz = 0 at t0 leaves qw's sign and the length free: IPOPT took qw = 84.6 (a near-identity
    rotation for any final qx, qy, qz: objective 0.0002 instead of 1.495) before this check."""
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0})
    ocp.final(dict(zip(("bob.qx", "bob.qy", "bob.qz"), TARGET[1:])))
    with pytest.raises(oc.ModelError, match=r"initial values of bob\.qw are not determined.*length is set by its "
                                            r"initial values"):
        check_problem(ocp, oc.Radau(4, degree=3))


def test_four_final_quaternion_components_are_refused_naming_the_one_to_leave_out():
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qw": 1.0, "bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0})
    ocp.final(dict(zip(("bob.qw", "bob.qx", "bob.qy", "bob.qz"), TARGET)))
    with pytest.raises(oc.ModelError, match=r"final values of all four .* over-determine.*'bob\.qw'"):
        check_problem(ocp, oc.Radau(4, degree=3))


def test_a_non_unit_initial_quaternion_is_refused():
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qw": 1.0, "bob.qx": 0.5, "bob.qy": 0.0, "bob.qz": 0.0})
    with pytest.raises(oc.ModelError, match=r"initial values of bob\.qw, .* not a unit quaternion \(\|q\| = 1\.118"):
        check_problem(ocp, oc.Radau(4, degree=3))


def test_four_initial_and_three_final_components_pass_the_check():
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qw": 1.0, "bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0})
    ocp.final(dict(zip(("bob.qx", "bob.qy", "bob.qz"), TARGET[1:])))
    d = check_problem(ocp, oc.Radau(4, degree=3))
    assert (d.position_dof, d.speed_dof) == (3, 3)       # a ball joint leaves three rotations
