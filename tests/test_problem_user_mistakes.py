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
