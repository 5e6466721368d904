"""A failed solve says what its last iterate violates, by name (IPOPT's 'Infeasible_Problem_Detected'
names nothing): path constraints by label, bounds and boundary values by quantity."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc


def _block_on_a_rail(coordinates: str, push_max: float):
    """A 1 kg block on a prismatic rail pushed by a bounded force, rest to rest 1 m in 1 s.

    Rest to rest over d = 1 m in T = 1 s needs |F| >= 4 m d / T^2 = 4 N somewhere (bang-bang), so a
    bound below that makes the problem infeasible, whatever the transcription.
    """
    model = oc.Model("rail_block", gravity=(0.0, 0.0, -9.81))
    block = model.add_body("block", 1.0, 0.01 * np.eye(3), rotation="321")
    oc.joints.prismatic(model, "rail", block.com, axis=(1, 0, 0))
    push = model.add_input("push")
    model.add_force("push", block.com, ca.vertcat(push, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=1.0, coordinates=coordinates)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
    ocp.final({"block.x": 1.0, "block.vbar_x": 0.0})
    ocp.bound("push", -push_max, push_max)
    ocp.subject_to(ocp.quantity("push"), -np.inf, push_max, "push limit")
    ocp.minimize_effort()
    return ocp


@pytest.mark.parametrize("coordinates", ["maximal", "joint"])
def test_an_infeasible_problem_names_what_the_last_iterate_violates(coordinates):
    ocp = _block_on_a_rail(coordinates, push_max=1.0)
    with pytest.raises(oc.OCPSolveError, match=r"most violated there: .*('block\.|'push)") as info:
        ocp.solve(oc.Radau(4, degree=3))
    found = info.value.solution.violations()
    assert found and all(amount > 1e-6 for _, amount, _ in found)
    sol = info.value.solution
    # each reported amount is what the samples show, independently recomputed
    for what, amount, t in found:
        k = int(np.argmin(abs(sol.t - t)))
        if what.startswith("final value of 'block.x'"):
            assert amount == pytest.approx(abs(sol.sample("block.x")[-1] - 1.0))
        if what.startswith("bound on 'push'") or what.startswith("path constraint 'push limit'"):
            assert amount == pytest.approx(max(abs(sol.sample("push")[k]) - 1.0, 0.0))


def test_a_solved_problem_violates_nothing():
    sol = _block_on_a_rail("joint", push_max=10.0).solve(oc.Radau(4, degree=3))
    assert sol.success and sol.violations() == []
