"""Trajectories queried by name; joint loads moved to other points (eqs. 28-29, 32-33)."""
from __future__ import annotations

import numpy as np
import pytest

from ocp_constraints import build_scene
from ocp_constraints.errors import ModelError
from ocp_constraints.scenes.tasks import simulate_scene


@pytest.fixture(scope="module")
def disk_run():
    scene = build_scene("sliding_disk")
    return scene, simulate_scene(scene, 1.0)


def test_contact_load_moved_to_the_center_of_mass_is_eq_29(disk_run):
    scene, traj = disk_run
    F, M = traj.load_about("contact", scene.model.bodies["disk"].com)
    lam = traj.sample("contact.n.lambda")
    psi, theta = traj.sample("disk.psi"), traj.sample("disk.theta")
    R = scene.model.parameters["radius"]
    # e2'' = R3(psi) R1(theta) E2; eq. (29): M_c = lambda (-R e2'' x E3) at the center of mass.
    e2pp = np.column_stack([-np.sin(psi) * np.cos(theta), np.cos(psi) * np.cos(theta), np.sin(theta)])
    expected = lam[:, None] * np.cross(-R * e2pp, [0, 0, 1.0])
    assert np.allclose(F, lam[:, None] * [0, 0, 1.0], rtol=0, atol=1e-12)
    assert np.allclose(M, expected, rtol=0, atol=1e-12)


def test_quantities_are_found_by_name_and_unknown_names_are_listed(disk_run):
    _, traj = disk_run
    assert np.array_equal(traj.sample("disk.theta"), traj.q[:, 4])
    assert np.array_equal(traj.sample("disk.omega_z"), traj.u[:, 5])
    with pytest.raises(ModelError, match="no quantity named 'disk.spin'"):
        traj.sample("disk.spin")
    with pytest.raises(ModelError, match="no joint load 'hinge'"):
        traj.load_about("hinge", None)
