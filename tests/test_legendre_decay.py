"""The smoothness reading of ocp/legendre_decay.py: a jump is read as not smooth by the solution and by its companion
alike; a smooth, curved solution on degree-3 intervals (three coefficients) can look like a step to the solution's
own reading, and its companion's says otherwise (issue 19; a sixth newcomer's tracking pendulum lost a met 1e-4 to
that, results/bench/refinement_newcomer6.md, finding 1)."""
from __future__ import annotations

import casadi as ca
import numpy as np

import ocp_constraints as oc
from ocp_constraints.ocp.legendre_decay import DECAY_LIMIT, legendre_decay
from ocp_constraints.ocp.schemes import Radau

from test_mesh_refinement_switches import T_FINAL, T_SWITCH, _block


def _whirl() -> oc.OptimalControlProblem:
    """A rod turned a full turn, rest to rest in 2 s, least effort, no bound: its solution is smooth everywhere and
    its hinge force turns with it (2 rad over each of 8 intervals)."""
    model = oc.Model("whirl", gravity=(0.0, -9.81, 0.0))
    rod = model.add_body("rod", 1.0, np.diag([1e-4, 1 / 12, 1 / 12]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("P", (-0.5, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("tau")))
    problem = oc.OptimalControlProblem(model, t_final=2.0)
    problem.initial({"rod.psi": -np.pi / 2, "rod.omega_z": 0.0})
    problem.final({"rod.psi": 1.5 * np.pi, "rod.omega_z": 0.0})
    problem.set_guess("rod.psi", lambda t: -np.pi / 2 + np.pi * np.asarray(t))
    problem.minimize_effort()
    return problem


def _pair(problem, intervals: int):
    sol = problem.solve(Radau(intervals, degree=3))
    return sol, problem.solve(Radau(intervals, degree=5), warm_start=sol)


def test_a_smooth_curved_solution_on_degree_3_intervals_is_smooth_by_its_companions_reading():
    sol, companion = _pair(_whirl(), 8)
    own, both = legendre_decay(sol)[0], legendre_decay(sol, companion)[0]
    assert own.max() > DECAY_LIMIT          # three coefficients alone: read as a step (measured 1.09)
    assert both.max() < DECAY_LIMIT         # nothing switches in this problem (measured 0.10)


def test_a_jump_inside_an_interval_is_not_smooth_by_either_reading():
    sol, companion = _pair(_block(), 4)
    both = legendre_decay(sol, companion)[0]
    k = int(np.searchsorted(sol.transcription.scheme.mesh_fractions, T_SWITCH / T_FINAL) - 1)
    assert both[k] > DECAY_LIMIT            # the push jumps at 1/3 of the horizon (Pontryagin), inside interval k
    assert np.all(np.delete(both, k) < DECAY_LIMIT)
