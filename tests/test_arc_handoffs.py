"""An input's arc handing its bound on to a path constraint's at one junction (ocp/arc_handoffs.py), checked against
a closed form: a power-limited block.

A block of m = 2 kg on a rail (no gravity) is pushed by F, |F| <= FMAX = 2 N and |F v| <= PMAX = 2 W, D = 10 m rest
to rest in T = 7 s, least int F^2. Pontryagin: F = FMAX until the power reaches PMAX at t1 = m PMAX / FMAX^2 = 1 s
(v = t); then F = PMAX / v, v = sqrt(2 t - 1) (m v dv = PMAX dt) until v = 2 m/s, F = 1 N at t2 = 2.5 s, where the
unconstrained F = -(t - 3.5) (linear: the costate's) takes over continuously; the second half mirrors the first.
The distance checks the closed form: 1/2 + 7/3 + 13/3 + 7/3 + 1/2 = 10. At t1 the force's arc ends at the very
instant the power's begins: one junction, not two (two overlapped by a sliver and made the NLP overconstrained).
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ocp_constraints import Model, OptimalControlProblem, joints
from ocp_constraints.ocp.arc_handoffs import handed_off, tied
from ocp_constraints.ocp.imposed_arcs import Arc

M, FMAX, PMAX, D, T = 2.0, 2.0, 2.0, 10.0, 7.0
T1, T2 = M * PMAX / FMAX**2, 2.5


def _powered_block() -> OptimalControlProblem:
    model = Model("powered_block", gravity=(0.0, 0.0, 0.0))
    block = model.add_body("block", M, np.diag([0.1, 0.2, 0.3]), rotation="321")
    joints.prismatic(model, "rail", block.com, axis=(1.0, 0.0, 0.0))
    model.add_force("push", block.com, ca.vertcat(model.add_input("F"), 0, 0))
    problem = OptimalControlProblem(model, t_final=T)
    problem.initial({"block.x": 0.0, "block.x_dot": 0.0})
    problem.final({"block.x": D, "block.x_dot": 0.0})
    problem.bound("F", -FMAX, FMAX)
    problem.subject_to(problem.quantity("F") * problem.quantity("block.x_dot"), -PMAX, PMAX, "power")
    problem.minimize_effort()
    return problem


def _closed_form(t: np.ndarray):
    """Position (m), speed (m/s) and force (N) of the optimum at times ``t``."""
    first = t <= T / 2
    s = np.where(first, t, T - t)          # the second half mirrors the first
    x = np.where(s <= T1, s**2 / 2,
                 np.where(s <= T2, 0.5 + (np.maximum(2 * s - 1, 0.0) ** 1.5 - 1) / 3,
                          0.5 + 7 / 3 + 2 * (s - T2) - (((s - 3.5) ** 3 + 1) / 3 - (s - T2)) / 4))
    v = np.where(s <= T1, s, np.where(s <= T2, np.sqrt(np.maximum(2 * s - 1, 0.0)), 2 - ((s - 3.5) ** 2 - 1) / 4))
    f = np.where(s <= T1, FMAX, np.where(s <= T2, PMAX / np.maximum(v, 1e-300), -(s - 3.5)))
    return np.where(first, x, D - x), v, np.where(first, f, -f)


def test_the_closed_form_covers_the_distance():
    """The closed form itself, by quadrature of its speed (independent of its position formula)."""
    t = np.linspace(0.0, T, 700_001)
    x, v, _ = _closed_form(t)
    assert np.trapezoid(v, t) == pytest.approx(D, abs=1e-9)
    assert np.abs(x - np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])).max() <= 1e-9


def test_a_force_handing_its_bound_to_the_power_limit_is_one_junction_and_meets_1e_6_against_the_closed_form():
    sol = _powered_block().solve(tolerance=1e-6)
    record = sol.mesh_refinement
    assert record["met"], record["message"]
    arcs = sorted((a["start"], a["end"], a["quantity"], a["value"]) for a in record["input_arcs"])
    assert [(q, v) for _, _, q, v in arcs] == [("F", FMAX), ("power", PMAX), ("power", -PMAX), ("F", -FMAX)]
    # the hand-offs: one time for the end of one arc and the start of the next, at the closed form's t1
    assert arcs[0][1] == arcs[1][0] and arcs[2][1] == arcs[3][0]
    assert arcs[0][1] == pytest.approx(T1, abs=1e-9) and arcs[3][0] == pytest.approx(T - T1, abs=1e-9)
    assert arcs[1][1] == pytest.approx(T2, abs=1e-6) and arcs[2][0] == pytest.approx(T - T2, abs=1e-6)
    t = np.linspace(0.0, T, 7001)
    x, v, f = _closed_form(t)
    true_states = max(np.abs(sol.interpolate("block.x", t) - x).max(), np.abs(sol.interpolate("block.vbar_x", t) - v).max())
    true_input = np.abs(sol.interpolate("F", t) - f).max() / FMAX         # the inputs' estimate: relative to the largest
    # the rate the problem names ("block.x_dot") reads the speed; the check of the end values reads it too (it raised)
    assert np.array_equal(sol.interpolate("block.x_dot", t), sol.interpolate("block.vbar_x", t))
    assert sol.violations() == []
    for true, estimate in ((true_states, record["estimate"]["states"]), (true_input, record["estimate"]["inputs"])):
        assert estimate / 10 <= true <= estimate <= 1e-6, (true, estimate)


def test_only_a_touching_pair_of_different_quantities_is_handed_off():
    """handed_off joins an arc's end and another quantity's start where their runs of active points touch or overlap;
    a gap of a free point between them, the same quantity, or a state's arc are left alone. tied lets the starting
    arc's mismatch place a shared junction."""
    force = Arc("F", 2.0, 0.0, 0.30)
    power = Arc("power", 2.0, 0.32, 0.5, path=True)
    joined = handed_off([force, power], [(0, 10), (10, 20)])
    assert joined[0].end == joined[1].start == pytest.approx(0.31)
    assert handed_off([force, power], [(0, 10), (12, 20)]) == [force, power]          # a free point between them
    assert handed_off([force, Arc("F", -2.0, 0.32, 0.5)], [(0, 10), (10, 20)])[0].end == 0.30     # the same quantity
    assert handed_off([force, Arc("x", 1.0, 0.32, 0.5, state=True)], [(0, 10), (10, 20)])[0].end == 0.30
    assert tied([(0, "end", 0.31), (1, "start", 0.31), (1, "end", 0.5)]).tolist() == [1, 1, 2]
