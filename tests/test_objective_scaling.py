"""The objective's scale in a refinement's warm solves (ocp/objective_scaling.py): its value against the
quadrature's closed form, and a closed-loop problem whose fine meshes IPOPT crawled on without it, checked
against the same problem in minimal coordinates."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.objective_scaling import MAX_GRADIENT, objective_scale


def _radau_weights(degree: int) -> np.ndarray:
    """Radau IIA quadrature weights on [0, 1], integrated from the Lagrange polynomials of the nodes."""
    from newcomer_reference import radau_coefficients

    return radau_coefficients(degree)[2][1:]


def _hinged_rod(t_final: float = 2.0) -> oc.OptimalControlProblem:
    model = oc.Model("rod", gravity=(0, -9.81, 0))
    rod = model.add_body("rod", 1.0, np.diag([1e-4, 1 / 12, 1 / 12]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("O", (-0.5, 0, 0)), axis=(0, 0, 1))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    problem = oc.OptimalControlProblem(model, t_final=t_final)
    problem.initial({"rod.psi": 0.0, "rod.omega_z": 0.0})
    problem.final({"rod.psi": 1.0, "rod.omega_z": 0.0})
    return problem


@pytest.mark.parametrize("weight", [1.0, 3.0])
def test_an_effort_objective_is_scaled_by_one_over_its_largest_quadrature_curvature(weight):
    """weight * int tau^2 dt on Radau 5, 8 intervals of T / 8: d^2 f / d tau_i^2 = 2 weight w_i, the largest w_i
    being (T / 8) max b_j (Radau weights b_j); the scale is its inverse where the gradient stays under 100."""
    problem = _hinged_rod()
    problem.minimize_effort(weight=weight)
    tr = problem.transcription(oc.Radau(8, degree=5))
    x0 = tr.initial_guess()
    expected = 1.0 / (2.0 * weight * (2.0 / 8) * _radau_weights(5).max())
    gradient = float(np.abs(np.asarray(tr.block.grad_f(x0, [])[1])).max())
    assert gradient * expected < MAX_GRADIENT          # the curvature decides here, not the gradient's ceiling
    assert objective_scale(tr.block, x0) == pytest.approx(expected, rel=1e-12)


def test_an_objective_without_curvature_is_left_as_it_is():
    """Least final time alone: no second derivative anywhere, so no scale (1)."""
    problem = _hinged_rod()
    problem.t_final_bounds = (0.5, 5.0)
    problem.bound("motor", -5.0, 5.0)
    problem.minimize_final_time()
    tr = problem.transcription(oc.Radau(6, degree=3))
    assert objective_scale(tr.block, tr.initial_guess()) == 1.0


# -- a slider-crank with its loop closed by hand (a newcomer's problem) ---------------------------------
R, L, M_CRANK, M_ROD, M_SLIDER, GAS, T = 0.1, 0.3, 0.5, 0.4, 0.6, 20.0, 0.5


def _rod_inertia(m: float, length: float) -> np.ndarray:
    return np.diag([1e-4, m * length**2 / 12, m * length**2 / 12])


def _slider_crank() -> oc.OptimalControlProblem:
    model = oc.Model("slider_crank", gravity=(0, -9.81, 0))
    crank = model.add_body("crank", M_CRANK, _rod_inertia(M_CRANK, R), rotation="321")
    rod = model.add_body("rod", M_ROD, _rod_inertia(M_ROD, L), rotation="321")
    slider = model.add_body("slider", M_SLIDER, 1e-3 * np.eye(3), rotation="321")
    oc.joints.revolute(model, "O", crank.point("O", (-R / 2, 0, 0)), axis=(0, 0, 1))
    oc.joints.revolute(model, "A", rod.point("A", (-L / 2, 0, 0)), axis=(0, 0, 1), other=crank.point("A", (R / 2, 0, 0)))
    oc.joints.prismatic(model, "rail", slider.com, axis=(1, 0, 0))
    B = rod.point("B", (L / 2, 0, 0))
    for k in range(2):      # the closure in the plane, written by hand: B on the slider
        E = ca.DM.eye(3)[:, k]
        model.add_constraint(f"B.v{k + 1}", ca.dot(E, B.v) - ca.dot(E, slider.com.v), joint="B",
                             position=B.position[k] - slider.com.position[k])
    model.add_torque("motor", crank, ca.vertcat(0, 0, model.add_input("motor")))
    model.add_force("gas", slider.com, ca.vertcat(-GAS, 0, 0))
    problem = oc.OptimalControlProblem(model, t_final=T)
    problem.initial({"crank.psi": 0.0, "crank.omega_z": 0.0})
    problem.final({"crank.psi": math.pi, "crank.omega_z": 0.0})
    problem.minimize_effort()
    return problem


def _minimal_slider_crank():
    """The same mechanism in its one coordinate, the crank angle, from the bodies' energies (Lagrange)."""
    from newcomer_reference import LagrangeSystem, RigidBody, rot3

    q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
    A = R * ca.vertcat(ca.cos(q[0]), ca.sin(q[0]), 0)
    beta = -ca.asin(R * ca.sin(q[0]) / L)
    x_slider = ca.vertcat(A[0] + L * ca.cos(beta), 0, 0)
    bodies = [RigidBody(M_CRANK, _rod_inertia(M_CRANK, R), A / 2, rot3(q[0])),
              RigidBody(M_ROD, _rod_inertia(M_ROD, L), A + L / 2 * ca.vertcat(ca.cos(beta), ca.sin(beta), 0), rot3(beta)),
              RigidBody(M_SLIDER, 1e-3 * np.eye(3), x_slider, ca.DM.eye(3))]
    gravity = np.array([0.0, -9.81, 0.0])
    free = LagrangeSystem(q, w, bodies, gravity)
    return LagrangeSystem(q, w, bodies, gravity, free.torque_work(0, ca.vertcat(0, 0, w[0]))
                          + free.force_work(x_slider, ca.DM([-GAS, 0, 0])))


@pytest.mark.slow
def test_a_closed_loop_slider_crank_meets_1e_4_and_its_rod_force_agrees_with_lagranges_equations():
    """Without the scale the refinement stalled here (58 s, its estimate rising from 1.2e-4 to 7.6e-3: IPOPT
    regularized every iteration on the fine meshes). Now met; the rod's push on the slider along the rail,
    -(m_s x_s'' + gas), from the minimal-coordinate optimum (Radau 9 on 60 intervals in CasADi's Opti, started
    from ours only to pick the same local optimum), is within the multipliers' estimate of it."""
    from newcomer_reference import radau_solve

    sol = _slider_crank().solve(tolerance=1e-4, progress=False)
    record = sol.mesh_refinement
    assert record["met"], record.get("message")
    assert max(entry["objective_scale"] for entry in record["history"]) > 1.0

    system = _minimal_slider_crank()
    reference = radau_solve(system, 60, T, ca.sumsqr(system.w), {0: 0.0, 1: 0.0}, {0: math.pi, 1: 0.0}, degree=9,
                            guess_q=lambda s: np.asarray(sol.interpolate("crank.psi", s * T)).ravel())
    assert reference["objective"] == pytest.approx(sol.objective, rel=1e-8)
    t, X, W = reference["t"][1:], reference["X"][:, 1:], reference["W"][0]
    qdd = ca.SX.sym("qdd", 1)
    v = ca.jtimes(system.bodies[2].x, system.q, system.qd)
    slider_acceleration = ca.Function("a", [system.q, system.qd, qdd],
                                      [(ca.jtimes(v, system.q, system.qd) + ca.jtimes(v, system.qd, qdd))[0]])
    dynamics = ca.Function("qdd", [system.q, system.qd, system.w], [system.qdd])
    push = np.array([-(M_SLIDER * float(slider_acceleration(X[0, i], X[1, i], dynamics(X[0, i], X[1, i], W[i])))
                       + GAS) for i in range(len(t))])
    error = np.abs(np.asarray(sol.interpolate("B.v1.lambda", t)).ravel() - push).max()
    assert error / record["history"][-1]["load_scale"] <= record["estimate"]["multipliers"]
