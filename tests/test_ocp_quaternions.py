"""A quaternion body's boundary values in an optimal-control problem: the pre-solve check names what a
newcomer gets wrong, instead of a numpy 'SVD did not converge'; the NLP holds each quaternion's length,
so three or four given components solve (before, a silently rescaled quaternion or IPOPT running to its
iteration limit; issue 13: problems not in the suite)."""
from __future__ import annotations

import re
import warnings

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from scipy.optimize import least_squares

from ocp_constraints.mechanics.rotations import EulerSequence, UnitQuaternion
from ocp_constraints.ocp.diagnostics import check_problem

TARGET = (0.8686198214082874, 0.35438937171419277, 0.2968801535759501, 0.1782412788480126)   # unit


def _spherical_pendulum(rotation: str = "quaternion"):
    """A rod on a hand-written ball joint at its top end, three torques, rest to rest."""
    model = oc.Model("sph_q", gravity=(0.0, 0.0, -9.81))
    bob = model.add_body("bob", 1.0, np.diag([1 / 12, 1 / 12, 0.01]), rotation=rotation)
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


def test_three_initial_components_fix_the_quaternion_with_its_length():
    """qx = qy = qz = 0 at t0: the NLP's row |q|^2 = 1 fixes qw up to its sign (before that row, IPOPT took
    qw = 84.6, a near-identity rotation for any final orientation: objective 0.0002 instead of 1.495)."""
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0})
    d = check_problem(ocp, oc.Radau(4, degree=3))
    assert (d.position_dof, d.speed_dof) == (3, 3)


def _euler_321_reference(mesh) -> float:
    """The same rest-to-rest turn with the body on 3-2-1 Euler angles (another parameterization, another
    NLP): the final angles are those whose rotation tensor is the target quaternion's."""
    seq = EulerSequence("321")
    a = ca.SX.sym("a", 3)
    residual = ca.Function("R", [a], [ca.vec(seq.rotation(a) - ca.DM(UnitQuaternion().rotation(ca.DM(TARGET))))])
    angles = least_squares(lambda x: np.asarray(residual(x)).ravel(), np.zeros(3), xtol=1e-15, ftol=1e-15).x
    assert np.abs(np.asarray(residual(angles))).max() < 1e-12
    ocp = _spherical_pendulum(rotation="321")
    ocp.initial({"bob.psi": 0.0, "bob.theta": 0.0, "bob.phi": 0.0})
    ocp.final(dict(zip(("bob.psi", "bob.theta", "bob.phi"), angles)))
    return ocp.solve(mesh).objective


def test_a_turn_between_quaternions_given_by_three_and_four_components_reaches_the_euler_angle_optimum():
    """Four final components used to over-determine the quaternion (its length drifts under collocation:
    3,000 IPOPT iterations); with its length a row of the NLP at every point (and a slack in its
    kinematics), three initial and four final components solve, |q| = 1 throughout, and the optimum is
    the one the same problem has on Euler angles."""
    mesh = oc.Radau(5, degree=7)
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0})
    ocp.final(dict(zip(("bob.qw", "bob.qx", "bob.qy", "bob.qz"), TARGET)))
    sol = ocp.solve(mesh)
    q = np.vstack([sol.sample(f"bob.q{c}") for c in "wxyz"])
    assert np.abs(np.linalg.norm(q, axis=0) - 1.0).max() < 1e-9
    assert abs(q[0, 0]) == pytest.approx(1.0, abs=1e-9)
    assert sol.objective == pytest.approx(_euler_321_reference(mesh), rel=1e-6)     # measured 2e-8 apart


def test_a_non_unit_initial_quaternion_is_refused():
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qw": 1.0, "bob.qx": 0.5, "bob.qy": 0.0, "bob.qz": 0.0})
    with pytest.raises(oc.ModelError, match=r"initial values of bob\.qw, .* not a unit quaternion \(\|q\| = 1\.118"):
        check_problem(ocp, oc.Radau(4, degree=3))


def test_four_initial_and_three_final_components_pass_the_check_with_a_warning_that_qw_s_sign_is_free():
    ocp = _spherical_pendulum()
    ocp.initial({"bob.qw": 1.0, "bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0})
    ocp.final(dict(zip(("bob.qx", "bob.qy", "bob.qz"), TARGET[1:])))
    # qw = +-sqrt(1 - qx^2 - qy^2 - qz^2): two rotations (not q and -q), the pose IPOPT picks depends on its start.
    with pytest.warns(oc.AmbiguousPoseWarning, match=r"bob.qw = ([+-][\d.]+) or ([+-][\d.]+)") as caught:
        d = check_problem(ocp, oc.Radau(4, degree=3))
    values = sorted(abs(float(v)) for v in re.search(r"bob.qw = ([+-][\d.]+) or ([+-][\d.]+)", str(caught[0].message)).groups())
    assert values == pytest.approx([np.sqrt(1.0 - np.sum(np.square(TARGET[1:])))] * 2, abs=1e-3)
    assert (d.position_dof, d.speed_dof) == (3, 3)       # a ball joint leaves three rotations


def _satellite(coordinates: str, plane: bool = False):
    """A free-floating base on a quaternion with an arm on a library hinge, in zero gravity: in joint
    coordinates the base keeps its quaternion (its length row with it), the arm gets its hinge angle.
    ``plane``: the base's centre held at z = 0 by a hand-written constraint, which joint coordinates keep."""
    model = oc.Model("satellite", gravity=(0.0, 0.0, 0.0))
    base = model.add_body("base", 10.0, np.diag([1.0, 1.2, 1.5]), rotation="quaternion")
    arm = model.add_body("arm", 1.0, np.diag([0.01, 0.1, 0.1]), rotation="321")
    oc.joints.revolute(model, "shoulder", arm.point("S", (-0.5, 0, 0)), axis=(0, 0, 1), other=base.point("S", (0.5, 0, 0)))
    if plane:
        centre = base.point("C", (0.0, 0.0, 0.0))
        model.add_constraint("plane", centre.v[2], position=centre.position[2])
    model.add_torque("motor", arm, ca.vertcat(0, 0, model.add_input("tau")), reaction_body=base)
    ocp = oc.OptimalControlProblem(model, t_final=2.0, coordinates=coordinates)
    at_rest = {f"base.{s}": 0.0 for s in ("vbar_x", "vbar_y", "omega_x", "omega_y", "omega_z")}
    if not plane:
        at_rest.update({"base.z": 0.0, "base.vbar_z": 0.0})
    ocp.initial({"base.x": 0.0, "base.y": 0.0, "base.qw": 1.0, "base.qx": 0.0, "base.qy": 0.0,
                 "base.qz": 0.0, **at_rest, "arm.psi": 0.0, "arm.omega_z": 0.0})
    ocp.final({"arm.psi": 1.0, "arm.omega_z": 0.0, "base.omega_z": 0.0})
    ocp.minimize_effort()
    return ocp


@pytest.mark.parametrize("plane", [False, True], ids=["free", "held-in-a-plane"])
def test_a_free_floating_quaternion_base_solves_alike_in_joint_and_maximal_coordinates(plane):
    """Two NLPs (the base's quaternion and the arm's hinge angle; every body's own coordinates and the
    hinge's multipliers) of one problem reach one optimum, the base's quaternion unit in both. Held in
    a plane (a constraint the joint form keeps), the joint form's start takes the speeds from the guessed
    rates through the quaternion's rate matrix (4 rates, 3 speeds: a raw CasADi shape error before)."""
    mesh = oc.Radau(5, degree=7)
    joint, maximal = (_satellite(c, plane).solve(mesh) for c in ("joint", "maximal"))
    assert joint.transcription.problem.nlp_coordinates == "joint"
    for sol in (joint, maximal):
        q = np.vstack([sol.sample(f"base.q{c}") for c in "wxyz"])
        assert np.abs(np.linalg.norm(q, axis=0) - 1.0).max() < 1e-9
    # Two NLPs, two discretizations: the joint form's optimum is 6.5e-9 above the maximal one's at N = 5
    # (9e-10 at N = 10; the maximal one changes by 1e-11), and IPOPT's stopping point in joint coordinates
    # moves it by up to 3.2e-8 with the BLAS thread count (OPENBLAS_NUM_THREADS=1: 0.121072770959, 56
    # iterations; 2: 0.121072767863, 59), which other tests of a worker may set. A wrong treatment is off by orders
    # of magnitude (its silent rescaling: 0.0002 for 1.495), a wrong start does not solve at all.
    assert joint.objective == pytest.approx(maximal.objective, rel=1e-6)
    assert joint.sample("base.qz")[-1] == pytest.approx(maximal.sample("base.qz")[-1], abs=1e-6)
    assert abs(joint.sample("base.qz")[-1]) > 0.1         # the reaction turns the base: a real test of the coupling


@pytest.mark.parametrize("coordinates", ["maximal", "joint", "condensed"])
@pytest.mark.parametrize("mesh", [oc.Radau(4, degree=3), oc.Radau(3, degree=7), oc.Radau(mesh=(0, 0.3, 1.0), degrees=(5, 3))],
                         ids=["radau3", "radau7", "hp"])
def test_the_rows_released_at_the_ends_are_the_given_quaternions_lengths(coordinates, mesh):
    """Four given components at an end hold the length there: that end's row |q|^2 = 1 is released (a
    redundant row made IPOPT take 134 iterations where 16 do). The released rows are those rows: the NLP's
    constraint function there equals |q|^2 - 1 of the end's quaternion, at any decision vector."""
    ocp = _satellite(coordinates)
    ocp.final({"base.qw": 1.0, "base.qx": 0.0, "base.qy": 0.0, "base.qz": 0.0})
    tr = ocp.transcription(mesh)
    rows = tr._fixed_length_rows()
    w = np.random.default_rng(0).normal(size=tr.nlp["x"].numel())
    g = np.asarray(ca.Function("g", [tr.nlp["x"]], [tr.nlp["g"]])(w)).ravel()
    X = np.asarray(tr.layout.split(w)[0])
    names = getattr(tr.eqs, "coordinate_names", None) or tr.eqs.model.coordinate_names     # joint NLP: its own
    at = [names.index(f"base.q{c}") for c in "wxyz"]
    assert len(rows) == 2
    np.testing.assert_allclose(g[rows], [X[at, 0] @ X[at, 0] - 1.0, X[at, -1] @ X[at, -1] - 1.0], rtol=1e-12)
    lbg, ubg = tr._boundary_values()
    assert np.all(np.isinf(lbg[rows])) and np.all(np.isinf(ubg[rows]))


def test_a_final_quaternion_on_the_other_sheet_warns_with_both_rotations():
    """-q is q's orientation, but the NLP's quaternion path is continuous and ends at the given sign: from the
    identity, -TARGET needs the long way round (a sixth newcomer's rod: another motion, without a word). The
    angles in the warning against the rotation tensor's own angle, acos((tr R - 1) / 2)."""
    R = np.asarray(UnitQuaternion().rotation(ca.DM(TARGET)))
    short = np.arccos((np.trace(R) - 1.0) / 2.0)
    start = {"bob.qw": 1.0, "bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0}
    ocp = _spherical_pendulum()
    ocp.initial(start)
    ocp.final(dict(zip(("bob.qw", "bob.qx", "bob.qy", "bob.qz"), -np.asarray(TARGET))))
    with pytest.warns(oc.QuaternionSignWarning, match=r"bob\.qw, bob\.qx, bob\.qy, bob\.qz.*opposite sheets") as seen:
        check_problem(ocp, oc.Radau(4, degree=3))
    text = str(seen[0].message)
    assert f"at least {2 * np.pi - short:.3g} rad" in text and f"takes at least {short:.3g} rad" in text
    same_sheet = _spherical_pendulum()
    same_sheet.initial(start)
    same_sheet.final(dict(zip(("bob.qw", "bob.qx", "bob.qy", "bob.qz"), TARGET)))
    with warnings.catch_warnings():
        warnings.simplefilter("error", oc.QuaternionSignWarning)
        check_problem(same_sheet, oc.Radau(4, degree=3))
