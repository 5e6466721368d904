"""Forward simulation of every built-in scene: energy balance and constraint residuals."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import simpson

from ocp_constraints import SystemEquations, build_scene, consistent_state, simulate
from ocp_constraints.errors import SimulationError
from ocp_constraints.scenes.registry import builtin_scene_names
from ocp_constraints.scenes.tasks import energy_balance

CONSERVATIVE = ["pendulum", "sliding_cylinder", "sliding_disk", "rolling_disk", "ball_socket"]
_cache: dict[str, object] = {}


def simulated(name: str, **params):
    key = (name, tuple(sorted(params.items())))
    if key not in _cache:
        scene = build_scene(name, params)
        eqs = SystemEquations(scene.model)
        q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
        _cache[key] = simulate(eqs, q0, u0, 10.0)
    return _cache[key]


@pytest.mark.parametrize("name", CONSERVATIVE)
def test_conservative_scene_keeps_total_energy_over_10_s(name):
    traj = simulated(name)
    assert np.abs(traj.work).max() == 0.0 or np.abs(traj.work).max() < 1e-12  # e_C = 0: no work
    T, U = traj.energy()
    E = T + U
    scale = max(np.abs(E).max(), T.max())
    assert np.abs(E - E[0]).max() / scale <= 1e-8


@pytest.mark.parametrize("amplitude", [0.0, 0.5])
def test_whirling_energy_change_equals_motor_work(amplitude):
    traj = simulated("whirling", omega_amplitude=amplitude)
    lam4 = traj.sample("shaft.drive.lambda")
    Omega = 2.0 + amplitude * np.sin(traj.t)
    # Motor power lambda_4 Omega (eq. 27), integrated independently from the samples.
    motor_work = simpson(lam4 * Omega, x=traj.t)
    T, U = traj.energy()
    dE = (T + U)[-1] - (T + U)[0]
    assert abs(dE) > 1e-3  # the motor really does work here
    assert abs(dE - motor_work) <= 1e-6 * abs(motor_work)  # Simpson's rule error at dt = 0.01
    # The integrator's own quadrature of -lambda e: the drive only, to 1e-8.
    names = traj.eqs.constraint_names
    work = traj.work[-1]
    assert all(work[i] == 0.0 for i, n in enumerate(names) if n != "shaft.drive")
    assert energy_balance(traj)["relative_error"] <= 1e-8
    assert abs(dE - work[names.index("shaft.drive")]) <= 1e-8 * abs(dE)


@pytest.mark.parametrize("name", builtin_scene_names())
def test_constraint_residuals_stay_below_1e_9_over_10_s(name):
    traj = simulated(name)
    assert traj.t[-1] == pytest.approx(10.0)
    position, velocity = traj.residuals()
    assert position <= 1e-9
    assert velocity <= 1e-9


def test_simulation_stops_at_euler_singularity_and_keeps_what_it_had():
    # A 3-1-3 disk falling flat drives theta to 0, where the dual Euler basis is undefined.
    scene = build_scene("sliding_disk", {"theta0": 0.3, "psi_dot0": 0.0, "phi_dot0": 0.0, "theta_dot0": -2.0, "x_dot0": 0.0, "y_dot0": 0.0})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    with pytest.raises(SimulationError) as info:
        simulate(eqs, q0, u0, 2.0)
    message = str(info.value)
    assert "body 'disk'" in message and "theta" in message and "quaternion" in message
    partial = info.value.partial
    assert len(partial) > 1 and partial.t[-1] < 2.0
    assert np.all(np.isfinite(partial.lam))
