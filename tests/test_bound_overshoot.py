"""A state bound passed between the collocation points (ocp/bound_overshoot.py): the amount against the
interval polynomials refitted independently, and the refinement's message where a bound is touched at an instant."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.bound_overshoot import overshoots

X_MAX = 0.624       # m: 0.7 of the unbounded swing-up's largest cart position, reached once (a touch)


def _cart_pole() -> oc.OptimalControlProblem:
    """A cart-pole swung up rest to rest in 2 s, least int F^2, the cart held below X_MAX (a newcomer's problem)."""
    model = oc.Model("cart_pole_bounded", gravity=(0.0, -9.81, 0.0))
    cart = model.add_body("cart", 1.0, 0.01 * np.eye(3), rotation="321")
    pole = model.add_body("pole", 0.5, np.diag([0.5 / 12, 1e-4, 0.5 / 12]), rotation="321")
    oc.joints.prismatic(model, "rail", cart.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "hinge", pole.point("A", (0, 0.5, 0)), axis=(0, 0, 1), other=cart.com)
    model.add_force("push", cart.com, ca.vertcat(model.add_input("push"), 0, 0))
    problem = oc.OptimalControlProblem(model, t_final=2.0)
    problem.initial({"cart.x": 0.0, "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    problem.final({"cart.x": 0.0, "pole.psi": math.pi, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    problem.minimize_effort()
    problem.bound("cart.x", -10.0, X_MAX)
    return problem


def test_the_amount_past_a_bound_between_the_points_matches_the_interval_polynomials_refitted():
    """Radau 3 on 20 intervals: the bound holds at the points; each interval's cubic through its four points, fitted
    again by NumPy and read on 2,001 times, passes it by the amount found (which reads 16 times an interval: at most
    that, within 2%)."""
    sol = _cart_pole().solve(oc.Radau(20, degree=3))
    x, t, mesh = sol.sample("cart.x"), sol.t, sol.transcription.scheme.mesh_fractions * sol.t_final
    assert x.max() <= X_MAX + 1e-8
    largest = 0.0
    for k in range(20):
        inside = slice(3 * k, 3 * k + 4)
        fit = np.polynomial.Polynomial.fit(t[inside], x[inside], 3)
        largest = max(largest, float((fit(np.linspace(mesh[k], mesh[k + 1], 2001)) - X_MAX).max()))
    found = overshoots(sol)
    assert largest > 1e-4 and [name for name, _, _ in found] == ["cart.x"]
    assert largest * 0.98 <= found[0][1] <= largest + 1e-12


def test_a_refinement_says_where_its_solution_passes_a_bound_touched_at_an_instant(monkeypatch):
    """Where the touch is not imposed (here the arcs' imposition switched off, ocp/junction_times.TRIES), at 1e-4 the
    refinement stalls; its record and message give the bound passed between the points, by more than the tolerance,
    near the touch (0.6356 s in a reference with a mesh point there)."""
    from ocp_constraints.ocp import junction_times

    monkeypatch.setattr(junction_times, "TRIES", 0)
    sol = _cart_pole().solve(tolerance=1e-4, progress=False)
    record = sol.mesh_refinement
    passed = record["bounds_passed_between_points"]
    assert passed[0]["quantity"] == "cart.x" and passed[0]["amount"] > 1e-4 and abs(passed[0]["t"] - 0.6356) < 0.05
    assert "passes the bound on 'cart.x'" in record["message"]
    assert passed[0]["amount"] == pytest.approx(overshoots(sol)[0][1])


def test_a_bound_touched_at_an_instant_is_imposed_as_a_touch_and_no_longer_passed():
    """With the touch imposed (ocp/imposed_arcs.py: the cart at its bound with zero speed at one mesh point, placed at
    the root of the push's jump) 1e-4 is met, the touch within 1e-5 s of the reference's 0.6356429 s (the fourth
    newcomer's Lagrange reference, scripts/refinement_newcomer4), and the bound is not passed between the points by
    more than the tolerance."""
    sol = _cart_pole().solve(tolerance=1e-4, progress=False)
    record = sol.mesh_refinement
    assert record["met"], record["message"]
    [touch] = record["input_arcs"]
    assert touch["quantity"] == "cart.x" and touch["start"] == touch["end"] and abs(touch["start"] - 0.6356429) < 1e-5
    assert all(p["amount"] <= 1e-4 for p in record.get("bounds_passed_between_points") or [])
    assert all(amount <= 1e-4 for _, amount, _ in overshoots(sol))
