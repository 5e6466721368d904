"""Consistent initial states, and the errors for states that are not."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ocp_constraints import SystemEquations, build_scene, consistent_state
from ocp_constraints.errors import InconsistentStateError, ModelError
from ocp_constraints.errors import SingularConfigurationError


def _eqs(name, **params):
    scene = build_scene(name, params)
    return scene, SystemEquations(scene.model)


def test_rolling_disk_center_velocity_follows_from_the_rolling_condition():
    scene, eqs = _eqs("rolling_disk")
    q, u = consistent_state(eqs, scene.coordinates, scene.rates)
    # v_P = 0 with P = xbar - R e2'': vbar = omega x (x_P - xbar) reversed, in closed form.
    R, theta = 0.15, 1.2
    psid, thetad, phid = 2.0, 0.3, 10.0
    e1p = np.array([1.0, 0, 0])  # g_2 at psi = 0
    e2pp = np.array([0, math.cos(theta), math.sin(theta)])
    omega = psid * np.array([0, 0, 1.0]) + thetad * e1p + phid * np.array([0, -math.sin(theta), math.cos(theta)])
    vbar = -np.cross(omega, -R * e2pp)
    assert np.allclose(u[:3], vbar, atol=1e-14)
    assert np.allclose(u[3:], omega, atol=1e-14)


def test_singular_initial_euler_angles_are_reported_with_body_and_advice():
    scene, eqs = _eqs("sliding_disk", theta0=1e-6)
    with pytest.raises(SingularConfigurationError) as info:
        consistent_state(eqs, scene.coordinates, scene.rates)
    msg = str(info.value)
    assert "body 'disk'" in msg and "'313'" in msg and "theta" in msg and "quaternion" in msg


def test_coordinates_off_the_constraint_are_named():
    scene, eqs = _eqs("sliding_disk")
    coords = dict(scene.coordinates, **{"disk.z": scene.coordinates["disk.z"] + 1e-3})
    with pytest.raises(InconsistentStateError, match=r"constraint 'contact.n' at position level"):
        consistent_state(eqs, coords, scene.rates)


def test_rates_that_contradict_a_constraint_are_rejected():
    scene, eqs = _eqs("whirling")
    with pytest.raises(InconsistentStateError, match=r"contradict the constraints \['shaft.drive'\]"):
        consistent_state(eqs, scene.coordinates, {"body.psi_dot": 5.0})


def test_unknown_and_missing_names_are_errors():
    scene, eqs = _eqs("whirling")
    with pytest.raises(ModelError, match="unknown rate"):
        consistent_state(eqs, scene.coordinates, {"body.spin": 1.0})
    coords = dict(scene.coordinates)
    del coords["body.phi"]
    with pytest.raises(ModelError, match=r"missing for \['body.phi'\]"):
        consistent_state(eqs, coords, {})


def test_a_position_form_that_is_not_the_integral_of_the_constraint_is_named():

    from ocp_constraints import Model

    model = Model("slider", gravity=(0, 0, -9.81))
    block = model.add_body("block", 1.0, np.eye(3) * 0.1)
    # E3 . vbar = 0 integrates to z = 0, not to -z / 2.
    model.add_constraint("floor", block.vbar[2], position=-block.xbar[2] / 2)
    eqs = SystemEquations(model)
    coords = {f"block.{c}": 0.0 for c in ("x", "y", "z", "psi", "theta", "phi")}
    coords["block.theta"] = 1.0
    with pytest.raises(ModelError, match="position form of constraint 'floor'"):
        consistent_state(eqs, coords, {})


def test_projected_positions_keep_quaternions_unit_and_constraints_satisfied():
    """A body on quaternions hanging from a ball-and-socket, coordinates perturbed by 0.05:
    the projection lands on phi = 0 with |q| = 1 (found by the random-systems property test:
    normalizing only before the Newton steps left |q| = 1.002)."""
    import ocp_constraints as oc
    from ocp_constraints.mechanics.state import project_positions

    model = oc.Model("hanging", gravity=(0, 0, -9.81))
    body = model.add_body("b", 1.0, np.diag([0.1, 0.2, 0.3]), rotation="quaternion")
    oc.joints.ball_and_socket(model, "ball", body.point("A", (0.1, 0.2, 0.5)))
    eqs = oc.SystemEquations(model)
    rng = np.random.default_rng(3)
    q = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]) + 0.05 * rng.standard_normal(7)
    p = project_positions(eqs, q, 0.0)
    _, _, phi, _, _ = eqs.constraint_functions(p, np.zeros(eqs.nu), 0.0, np.zeros(0))
    assert np.abs(np.asarray(phi)).max() < 1e-12
    assert abs(np.linalg.norm(p[3:]) - 1.0) < 1e-12
