"""The checks before a solve decide ranks in no unit (mechanics/scaling.equilibrated): a well-posed problem is not
refused because its lengths are large. A rod of 100 km hinged at its end had Jacobian columns 5e4 times apart (angles
against positions) and was refused: its initial position "not determined", its hinge's constraints "redundant"."""
import math

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.mechanics.scaling import equilibrated
from ocp_constraints.ocp.diagnostics import check_problem


def _rod_problem(mass: float, length: float) -> oc.OptimalControlProblem:
    model = oc.Model("rod", gravity=(0.0, -9.81, 0.0))
    rod = model.add_body("rod", mass, mass * length**2 * np.diag([1 / 12, 0.0, 1 / 12]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, length / 2, 0.0]), axis=(0, 0, 1))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    ocp = oc.OptimalControlProblem(model, t_final=2.0 * math.sqrt(length))
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    return ocp


@pytest.mark.parametrize("length", [1e-4, 1.0, 1e5])
def test_a_hinged_rod_of_any_length_passes_the_checks(length):
    ocp = _rod_problem(10.0 * length, length)
    ocp.eqs.check_redundancy(np.zeros(ocp.eqs.nq))        # the hinge's five constraints are independent
    check_problem(ocp, oc.Radau(10, degree=3))            # its initial position is determined


def test_equilibration_keeps_the_rank_and_frees_the_singular_values_of_units():
    A = np.array([[1.0, 0.0, -5e4], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])      # full rank, columns 5e4 apart
    s = np.linalg.svd(equilibrated(A)[0], compute_uv=False)
    assert s.min() / s.max() > 0.3 and np.linalg.svd(A, compute_uv=False).min() < 1e-4
    B = np.array([[1.0, 2e3], [2.0, 4e3]])                                   # rank one in any units
    assert np.linalg.matrix_rank(equilibrated(B)[0]) == 1
