"""A problem's units and its objective's weight do not change its optimum (ocp/objective_scaling.small_objective_scale).

Reference: the Pontryagin extremal of the swing-up (a rod hinged at its end, min int tau^2, rest hanging to rest
upright), computed by shooting (:func:`ocp_constraints.bench.references.swing_up_reference`, 1 kg, 1 m, 2 s). By
dimensional analysis a rod of mass m and length L does the same motion in time sqrt(L / 1 m) as fast, its torque
m L / (1 kg m) as large. Before the objective was brought to order one, the 1 cm, 1 g rod's solve stopped after
5 IPOPT iterations, "optimal", 2.4 rad from the reference; the effort weighted 1e-12, 4.1 N m off in torque.
"""
import math

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.bench.references import swing_up_reference


def _swing_up(mass: float, length: float, weight: float = 1.0) -> oc.OptimalControlProblem:
    """examples/swing_up.py's problem for a rod of ``mass`` (kg) and ``length`` (m), its time and torque scaled."""
    T = 2.0 * math.sqrt(length)
    model = oc.Model("rod", gravity=(0.0, -9.81, 0.0))
    rod = model.add_body("rod", mass, mass * length**2 * np.diag([1 / 12, 0.0, 1 / 12]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, length / 2, 0.0]), axis=(0, 0, 1))
    torque = model.add_input("motor")
    model.add_torque("motor", rod, ca.vertcat(0, 0, torque))
    ocp = oc.OptimalControlProblem(model, t_final=T)
    ocp.bound("motor", -20.0 * mass * length, 20.0 * mass * length)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"], weight=weight)
    ocp.set_guess("rod.psi", lambda t: math.pi * t / T - np.sin(math.pi * t / T))
    return ocp


@pytest.fixture(scope="module")
def reference():
    return swing_up_reference()


def _errors(sol, reference, mass: float, length: float) -> tuple[float, float]:
    """The angle's error (rad) and the torque's relative to its reference's largest, at the solution's points."""
    time_scale, torque_scale = math.sqrt(length), mass * length
    t = np.asarray(sol.t) / time_scale
    psi = np.abs(np.asarray(sol.sample("rod.psi")) - reference.states(t)[0]).max()
    tau = reference.torque(t)
    return psi, np.abs(np.asarray(sol.sample("motor")) / torque_scale - tau).max() / np.abs(tau).max()


def test_a_rod_of_one_centimetre_and_one_gram_meets_the_reference_as_the_metre_rod_does(reference):
    # Radau 6 x 20 on the 1 m rod: 3.6e-9 rad and 4.1e-8 of the torque from the reference.
    # 100 um and 1 ug: an objective of 9e-22, which a floor meant for targets reached exactly (1e-14) left unscaled
    for mass, length in ((1.0, 1.0), (1e-6, 1e-4), (1e-3, 1e-2)):
        sol = _swing_up(mass, length).solve(oc.Radau(20, degree=6))
        psi, tau = _errors(sol, reference, mass, length)
        assert psi < 1e-7 and tau < 1e-6, (mass, length, psi, tau)
    assert "rescaled" in sol.stats      # the small rod's objective (9e-11 N^2 m^2 s) was brought to one


def test_hermite_simpson_on_the_small_rod_meets_the_reference_as_the_metre_rod_does(reference):
    # Solved again from its own start, not from the unscaled solve's end: from there it stayed in another basin
    # (13.67 in the metre rod's units for 8.913, the swing 2.7 rad apart). Hermite-Simpson N = 60 on the metre rod:
    # 2.9e-6 rad and 1.3e-3 of the torque from the reference.
    for mass, length in ((1.0, 1.0), (1e-3, 1e-2)):
        psi, tau = _errors(_swing_up(mass, length).solve(oc.HermiteSimpson(60)), reference, mass, length)
        assert psi < 1e-5 and tau < 1e-2, (mass, length, psi, tau)


def test_the_objectives_weight_does_not_change_the_optimum(reference):
    for weight in (1.0, 1e-6, 1e-12):
        psi, tau = _errors(_swing_up(1.0, 1.0, weight).solve(oc.Radau(20, degree=6)), reference, 1.0, 1.0)
        assert psi < 1e-7 and tau < 1e-6, (weight, psi, tau)


def test_accuracy_on_request_holds_in_small_units(reference):
    sol = _swing_up(1e-3, 1e-2).solve(tolerance=1e-6)
    r = sol.mesh_refinement
    assert r["met"], r["message"]
    psi, _ = _errors(sol, reference, 1e-3, 1e-2)
    assert psi <= r["estimate"]["states"]


def test_accuracy_on_request_refuses_a_problem_without_an_objective():
    ocp = _swing_up(1.0, 1.0)
    ocp.integral_terms.clear()
    with pytest.raises(oc.ModelError, match="needs an objective"):
        ocp.solve(tolerance=1e-4)
    assert ocp.solve(oc.Radau(10, degree=3)).success      # a feasible motion on a fixed mesh, as before
