"""A terminal (Mayer) cost, ``problem.minimize_terminal``: a block pushed toward a target it need not reach,
against the closed form of Pontryagin's principle, in joint and maximal coordinates, to a tolerance, after an
edit, and refused where it reads a load."""
import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.errors import ModelError

M, H, W, D, T = 1.2, 0.1, 50.0, 1.0, 1.5     # kg, m (push offset), 1/m^2 (target weight), m, s


def block(coordinates: str = "auto") -> oc.OptimalControlProblem:
    """A block on a rail (zero gravity) pushed by F at a point H off its centre: the rail's moment is H F."""
    model = oc.Model("mayer_block", gravity=(0.0, 0.0, 0.0))
    b = model.add_body("block", M, np.diag([0.01, 0.01, 0.01]), rotation="321")
    oc.joints.prismatic(model, "rail", b.com, axis=(1, 0, 0))
    F = model.add_input("F")
    model.add_force("push", b.point("P", (0.0, H, 0.0)), ca.vertcat(F, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=T, coordinates=coordinates)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
    ocp.minimize_effort(["F"])
    return ocp


def closed_form(t):
    """min W (x(T) - D)^2 + int F^2, m x'' = F, x(0) = v(0) = 0, v(T) free. Pontryagin: p1 constant, p2(T) = 0, so
    F = c (T - t), x(T) = c T^3 / (3 m), and the transversality p1 = 2 W (x(T) - D) gives c (1 + W T^3 / (3 m^2))
    = W D / m."""
    c = (W * D / M) / (1.0 + W * T**3 / (3.0 * M**2))
    x = c * (T * t**2 / 2 - t**3 / 6) / M
    xT = c * T**3 / (3 * M)
    return c * (T - t), x, W * (xT - D) ** 2 + c**2 * T**3 / 3


@pytest.mark.parametrize("coordinates", ["joint", "maximal", "condensed"])
def test_a_terminal_cost_gives_pontryagins_optimum(coordinates):
    """The optimal push is linear in time: Radau 5 holds it exactly, so the input, the position, the rail's
    moment multiplier (H F, Newton-Euler of the block) and the objective meet the closed form to IPOPT's accuracy."""
    ocp = block(coordinates)
    ocp.minimize_terminal(W * (ocp.quantity("block.x") - D) ** 2)
    sol = ocp.solve(oc.Radau(6, degree=5))
    assert ocp.nlp_coordinates == coordinates
    t = np.asarray(sol.t)
    F, x, J = closed_form(t)
    assert np.max(np.abs(np.asarray(sol.sample("F"))[1:] - F[1:])) < 1e-7
    assert np.max(np.abs(np.asarray(sol.sample("block.x")) - x)) < 1e-8
    assert abs(sol.objective - J) < 1e-8 * J
    moment = np.asarray(sol.sample("rail.w3.lambda"))[1:]
    assert np.max(np.abs(np.abs(moment) - H * np.abs(F[1:]))) < 1e-7


def test_a_terminal_term_added_after_a_solve_takes_effect():
    """Without the target the optimum is no push at all; adding the terminal term after that solve moves it."""
    ocp = block()
    sol = ocp.solve(oc.Radau(6, degree=5))
    assert abs(sol.objective) < 1e-12
    ocp.minimize_terminal(W * (ocp.quantity("block.x") - D) ** 2)
    sol = ocp.solve(oc.Radau(6, degree=5))
    assert sol.objective == pytest.approx(closed_form(np.array([0.0]))[2], rel=1e-8)


def test_a_terminal_cost_under_a_tolerance():
    """Mesh refinement carries the terminal cost: met, the final position within the tolerance of the closed form."""
    ocp = block()
    ocp.minimize_terminal(W * (ocp.quantity("block.x") - D) ** 2)
    sol = ocp.solve(tolerance=1e-6)
    assert sol.mesh_refinement["met"]
    assert abs(float(np.asarray(sol.sample("block.x"))[-1]) - closed_form(np.array([T]))[1][0]) < 1e-6


def test_a_terminal_cost_of_a_load_is_refused_by_name():
    ocp = block("maximal")
    with pytest.raises(ModelError, match="terminal term 'rail moment'.*multipliers"):
        ocp.minimize_terminal(ocp.multiplier("rail.w3") ** 2, label="rail moment")
    with pytest.raises(ModelError, match="weight of the terminal term"):
        ocp.minimize_terminal(ocp.quantity("block.x"), weight=float("nan"))


def test_a_terminal_cost_of_the_final_time_is_the_minimum_time_trade_off():
    """``minimize_terminal(2 t)`` with a free final time: rest to rest over D at least int F^2 costs 12 m^2 D^2 / T^3,
    so J(T) = 2 T + 12 m^2 D^2 / T^3 is least at T = (18 m^2 D^2)^(1/4) (and minimize_final_time(2) says the same)."""
    ocp = block()
    ocp.t_final_bounds = (0.5, 5.0)
    ocp.final({"block.x": D, "block.vbar_x": 0.0})
    ocp.minimize_terminal(2.0 * ocp.model.t, label="time")
    sol = ocp.solve(oc.Radau(10, degree=5))
    T_opt = (18 * M**2 * D**2) ** 0.25
    assert sol.t_final == pytest.approx(T_opt, rel=1e-8)
    assert sol.objective == pytest.approx(2 * T_opt + 12 * M**2 * D**2 / T_opt**3, rel=1e-9)
