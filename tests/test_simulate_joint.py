"""Forward simulation in joint coordinates (SimulationOptions(coordinates="joint"), dynamics/joint_simulation.py):
the pendulum against the hand-derived 1-DOF balance (bench/references.py, DOP853), a two-link chain against
the maximal-coordinate simulation (a second derivation: KKT system with projection) and against its energy,
and the models it refuses with a message that names the way out."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ocp_constraints import Model, SystemEquations, build_scene, consistent_state, joints, simulate
from ocp_constraints.bench.references import pendulum_reference
from ocp_constraints.dynamics.simulate import SimulationOptions
from ocp_constraints.errors import ModelError


def test_pendulum_in_joint_coordinates_meets_the_hand_balance_and_its_multipliers():
    scene = build_scene("pendulum")
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 3.0, SimulationOptions(rtol=1e-12, atol=1e-12, coordinates="joint"))
    assert traj.success and len(traj.t) == 301
    ref = pendulum_reference(scene.model.parameters, traj.t, 1e-13)
    scale = max(float(np.abs(v).max()) for v in ref["lambda"].values())
    state = max(float(np.abs(traj.sample(k) - v).max()) for k, v in ref["states"].items())
    lam = max(float(np.abs(traj.sample(k) - v).max()) for k, v in ref["lambda"].items()) / scale
    assert state < 1e-10 and lam < 1e-10, (state, lam)
    phi, velocity = traj.residuals()
    assert phi < 1e-13 and velocity < 1e-12          # the joints hold by construction: nothing to project
    assert traj.max_drift == (0.0, 0.0)


def _chain() -> tuple[SystemEquations, np.ndarray, np.ndarray]:
    """Two rods on hinges about E3 and E1 (a spatial double pendulum), released from rest."""
    model = Model("chain", gravity=(0.0, -9.81, 0.0))
    inertia = np.diag([0.1, 0.02, 0.1])
    a = model.add_body("a", 1.0, inertia, rotation="321")
    b = model.add_body("b", 0.5, inertia, rotation="321")
    joints.revolute(model, "h1", a.point("top", (0.0, 0.5, 0.0)), axis=(0, 0, 1))
    joints.revolute(model, "h2", b.point("top", (0.0, 0.4, 0.0)), axis=(1, 0, 0), other=a.point("bottom", (0.0, -0.5, 0.0)))
    eqs = SystemEquations(model)
    s, r = math.radians(50), 0.3
    Rz = np.array([[math.cos(s), -math.sin(s), 0], [math.sin(s), math.cos(s), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    xa = -Rz @ [0.0, 0.5, 0.0]                                 # a's top at the origin (the hinge's anchor)
    xb = xa + Rz @ [0.0, -0.5, 0.0] - Rz @ Rx @ [0.0, 0.4, 0.0]  # b's top at a's bottom; 3-2-1 angles (s, 0, r)
    coords = {"a.x": xa[0], "a.y": xa[1], "a.z": xa[2], "a.psi": s, "a.theta": 0.0, "a.phi": 0.0,
              "b.x": xb[0], "b.y": xb[1], "b.z": xb[2], "b.psi": s, "b.theta": 0.0, "b.phi": r}
    q0, u0 = consistent_state(eqs, coords, {"b.phi_dot": 1.0})
    return eqs, q0, u0


def test_a_chain_in_joint_coordinates_equals_the_maximal_simulation_and_keeps_its_energy():
    eqs, q0, u0 = _chain()
    opts = dict(rtol=1e-11, atol=1e-11)
    joint = simulate(eqs, q0, u0, 1.0, SimulationOptions(coordinates="joint", **opts))
    maximal = simulate(eqs, q0, u0, 1.0, SimulationOptions(coordinates="maximal", compiled="never", **opts))
    assert np.abs(joint.q - maximal.q).max() < 1e-8 and np.abs(joint.u - maximal.u).max() < 1e-8
    scale = np.abs(maximal.lam).max()
    assert np.abs(joint.lam - maximal.lam).max() < 1e-8 * scale
    T, U = joint.energy()
    E = T + U
    assert np.abs(E - E[0]).max() < 1e-9 * max(1.0, abs(E[0]))


def test_models_the_joint_coordinates_do_not_cover_are_refused_with_the_way_out():
    scene = build_scene("sliding_disk")                       # a contact constraint: no library joint
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    with pytest.raises(ModelError, match="coordinates='maximal'"):
        simulate(eqs, q0, u0, 0.1, SimulationOptions(coordinates="joint"))
    with pytest.raises(ModelError, match="'coordinates' must be 'maximal' or 'joint'"):
        simulate(eqs, q0, u0, 0.1, SimulationOptions(coordinates="minimal"))
