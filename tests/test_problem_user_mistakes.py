"""Mistakes a newcomer makes while writing an optimal-control problem are refused where they are made,
with a message naming the offending thing, before any transcription or IPOPT (issue 13)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc


def _disk_on_a_plane():
    """A disk on a plane (normal E3) by hand: a contact joint with a normal and a tangential row."""
    model = oc.Model("disk", gravity=(-3.0, 0.0, -9.0))
    disk = model.add_body("disk", 1.0, 0.01 * np.diag([1.0, 2.0, 1.0]), rotation="213")
    c = disk.com
    model.add_constraint("contact.t", ca.dot(ca.DM([1, 0, 0]), c.v + ca.cross(disk.omega, ca.DM([0, 0, -0.1]))),
                         joint="contact")
    model.add_constraint("contact.n", c.v[2], joint="contact", position=c.position[2] - 0.1)
    tau = model.add_input("axle")
    model.add_torque("axle", disk, ca.vertcat(0, tau, 0))
    return oc.OptimalControlProblem(model, t_final=1.0)


def test_a_reversed_path_constraint_is_refused_with_its_label():
    ocp = _disk_on_a_plane()
    normal = ocp.joint_force("contact")[2]
    with pytest.raises(oc.ModelError, match=r"path constraint 'normal force'.*lower 100.0, upper 10.0.*swap"):
        ocp.subject_to(normal, 100.0, 10.0, "normal force")
    with pytest.raises(oc.ModelError, match="path constraint 'p'"):
        ocp.subject_to(normal, math.nan, 1.0, "p")
    assert ocp.path_constraints == []          # nothing half-added


@pytest.mark.parametrize("weight", [math.nan, math.inf])
def test_a_non_finite_objective_weight_is_refused_with_the_term(weight):
    ocp = _disk_on_a_plane()
    with pytest.raises(oc.ModelError, match=r"weight of the objective term 'effort' must be a finite number"):
        ocp.minimize_effort(weight=weight)
    with pytest.raises(oc.ModelError, match=r"weight of the objective term 'track disk.x'"):
        ocp.track("disk.x", lambda t: 0 * t, weight=weight)
    assert ocp.integral_terms == []


def test_a_reference_written_with_numpy_or_scipy_is_refused_naming_what_to_write_instead():
    # SciPy's CubicSpline of the CasADi symbol returns NaN and math.sin's float() of it NaN: before, IPOPT stopped
    # with 'Invalid_Number_Detected' after 0 iterations, naming nothing.
    from scipy.interpolate import CubicSpline

    spline = CubicSpline([0.0, 0.5, 1.0], [0.0, 1.0, 0.0])
    ocp = _disk_on_a_plane()
    for reference, said in ((spline, "it returned nan"), (math.sin, "it returned nan"),
                            (lambda t: ca.vertcat(t, t), "it returned 2 x 1 values"),
                            (lambda t: t.no_such_method(), "calling it raised AttributeError")):
        with pytest.raises(oc.ModelError, match=rf"track\('disk.x', reference\).*ca.pw_lin.*{said}"):
            ocp.track("disk.x", reference)
    assert ocp.integral_terms == []
    ocp.track("disk.x", lambda t: ca.pw_lin(t, ca.DM([0.0, 0.5, 1.0]), ca.DM([0.0, 1.0, 0.0])))    # the advice works
    ocp.track("disk.y", lambda t: 0.3)                                                               # a constant is fine
    assert len(ocp.integral_terms) == 2


def test_a_non_finite_final_time_weight_is_refused():
    ocp = _disk_on_a_plane()
    ocp.t_final_bounds = (0.5, 2.0)
    with pytest.raises(oc.ModelError, match="weight of the final time must be a finite number"):
        ocp.minimize_final_time(math.nan)
    assert ocp.time_weight == 0.0


@pytest.mark.parametrize("mu", [-0.5, math.nan, math.inf])
def test_a_negative_or_non_finite_friction_coefficient_is_refused(mu):
    """mu = -0.5 used to be taken as 0.5 (it enters squared) after 791 IPOPT iterations."""
    ocp = _disk_on_a_plane()
    with pytest.raises(oc.ModelError, match=r"friction_cone\('contact'\): the friction coefficient mu"):
        ocp.friction_cone("contact", mu)
    assert ocp.path_constraints == []


def test_a_zero_friction_cone_normal_is_refused():
    ocp = _disk_on_a_plane()
    with pytest.raises(oc.ModelError, match=r"friction_cone\('contact'\): normal must be 3 finite numbers"):
        ocp.friction_cone("contact", 0.5, normal=(0, 0, 0))


def test_a_valid_friction_cone_still_adds_its_two_rows():
    ocp = _disk_on_a_plane()
    ocp.friction_cone("contact", 0.0)
    assert [c.label for c in ocp.path_constraints] == ["contact normal force", "contact friction cone"]


def test_a_misspelt_quantity_gets_the_closest_names_not_every_name():
    """The message used to list all 18 names of each body (70 for a four-body model) and no suggestion."""
    ocp = _disk_on_a_plane()
    with pytest.raises(oc.ModelError, match=r"no quantity named 'axel' in model 'disk'; did you mean 'axle'\?") as info:
        ocp.initial({"axel": 1.0})
    assert "'disk.omega_y'" not in str(info.value)
    with pytest.raises(oc.ModelError, match=r"did you mean 'disk.psi'"):
        ocp.bound("disk.pis", 0.0, 1.0)
    assert ocp.initial_values == {} and ocp.bounds == {}


def _block(free_time: bool = False):
    """A 2 kg block on a rail (prismatic joint along E1), pushed by F, rest to rest over 1 m in 1 s (or free time)."""
    model = oc.Model("block", gravity=(0.0, 0.0, -9.81))
    block = model.add_body("block", 2.0, np.diag([0.1, 0.2, 0.3]), rotation="321")
    oc.joints.prismatic(model, "rail", block.com, axis=(1.0, 0.0, 0.0))
    F = model.add_input("F")
    model.add_force("push", block.com, ca.vertcat(F, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=1.0, t_final_bounds=(0.1, 5.0) if free_time else None)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
    ocp.final({"block.x": 1.0, "block.vbar_x": 0.0})
    return ocp


@pytest.mark.parametrize("lower, upper", [(math.nan, 1.0), (0.0, math.nan), (math.inf, math.inf),
                                          (-math.inf, -math.inf)])
def test_a_bound_that_is_not_a_number_or_infinite_on_the_wrong_side_is_refused_at_bound(lower, upper):
    """They reached IPOPT as a raw CasADi 'Ill-posed problem detected: LBX[63]'."""
    ocp = _block()
    with pytest.raises(oc.ModelError, match=r"bound on 'F': got lower .*a bound is a number, or -inf"):
        ocp.bound("F", lower, upper)
    assert "F" not in ocp.bounds


def test_a_method_that_is_not_a_scheme_is_refused_naming_the_schemes():
    """solve('radau') was a raw AttributeError ('str' object has no attribute 'mesh_fractions')."""
    with pytest.raises(oc.ModelError, match=r"method must be a scheme such as oc\.Radau\(50, degree=3\).*got 'radau'"):
        _block().solve("radau")
    with pytest.raises(oc.ModelError, match=r"method must be a scheme"):
        _block().solve("radau", tolerance=1e-4)


def test_a_horizon_edited_after_construction_is_checked_at_solve():
    """t_final = -1 set on the object ran IPOPT to 'Diverging_Iterates'; t_final_bounds = None after
    minimize_final_time solved a fixed time with the objective 0."""
    ocp = _block()
    ocp.minimize_effort()
    ocp.t_final = -1.0
    with pytest.raises(oc.ModelError, match=r"t_final must be a positive number of seconds, got -1\.0"):
        ocp.solve(oc.Radau(5, degree=3))
    timed = _block(free_time=True)
    timed.bound("F", -10.0, 10.0)
    timed.minimize_final_time()
    timed.t_final_bounds = None
    with pytest.raises(oc.ModelError, match=r"weighs the final time .* but the final time is fixed"):
        timed.solve(oc.Radau(5, degree=3))


def test_max_refinements_is_a_solve_option_as_the_refinement_message_says():
    """The message "raise max_refinements" named an option problem.solve did not take (a TypeError)."""
    ocp = _block()
    ocp.minimize_effort()
    ocp.bound("F", -10.0, 10.0)        # the push saturates (12 N unbounded): not met at 1e-8 on the first mesh
    sol = ocp.solve(tolerance=1e-8, max_refinements=0)
    mr = sol.mesh_refinement
    assert len(mr["history"]) == 1 and mr["met"] is False
    assert "max_refinements (solve(..., max_refinements=N), --max-refinements N)" in mr["message"]
    for bad in (-1, 1.5, True):
        with pytest.raises(oc.ModelError, match="max_refinements must be a whole number >= 0"):
            ocp.solve(tolerance=1e-4, max_refinements=bad)
    with pytest.raises(oc.ModelError, match=r"max_refinements applies to solve\(tolerance=\.\.\.\) only"):
        ocp.solve(oc.Radau(5, degree=3), max_refinements=2)


def test_results_asked_outside_the_horizon_or_by_a_time_name_say_what_to_do():
    """interpolate past t_final extrapolated the polynomial silently (-4.0 for x on a 1 s horizon, the block going
    0 -> 1); sample('t') ran its sentences together and did not name .t."""
    ocp = _block()
    ocp.minimize_effort()
    sol = ocp.solve(oc.Radau(4, degree=3))
    assert sol.interpolate("block.x", [0.0, 1.0]) == pytest.approx([0.0, 1.0], abs=1e-8)
    with pytest.raises(oc.ModelError, match=r"interpolate\('block\.x'\): time\(s\) \[2\.0\] s lie outside the horizon "
                                            r"0 \.\.\. 1 s"):
        sol.interpolate("block.x", [0.5, 2.0])
    with pytest.raises(oc.ModelError, match=r"no quantity named 't' in .*\. The sample times are the result's \.t"):
        sol.sample("t")


def test_minimize_effort_refuses_a_quantity_that_is_not_an_input():
    """minimize_effort(['block.x']) added int x^2 dt silently; the docstring says inputs."""
    ocp = _block()
    with pytest.raises(oc.ModelError, match=r"minimize_effort: \['block\.x'\] are not inputs .*minimize_integral"):
        ocp.minimize_effort(["block.x"])
    assert ocp.integral_terms == []
