"""A block on a rail tracking measured samples, and its Pontryagin solution: the check of mesh points at the
samples (:mod:`ocp_constraints.ocp.time_breakpoints`; ``scripts/refinement_time_breakpoints.py``,
``tests/test_time_breakpoints.py``).

The block (``M`` kg) moves along E1 pushed by ``u``, from rest at x = 0; the objective is
``int W (x - r)^2 + u^2 dt`` over ``T`` s, ``r`` linear between samples at 30 Hz (never a mesh point of halved
uniform meshes). Reference: the two-point problem of Pontryagin's conditions (``u = -p2 / (2 M)``,
``p1' = -2 W (x - r)``, ``p2' = -p1``, free final state) by SciPy's ``solve_bvp`` at tol 1e-8, which agrees with
tol 1e-10 to 4e-13 m in x and 3e-12 m/s in v: a method independent of the library.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..mechanics.model import Model
from ..ocp.problem import OptimalControlProblem

T, M, W = 1.0, 1.0, 1e4
SAMPLES = np.linspace(0.0, T, 31)
VALUES = 0.1 * np.sin(2 * np.pi * SAMPLES)


def sampled_tracking_block() -> OptimalControlProblem:
    """The block tracking ``VALUES`` at ``SAMPLES`` (``ca.pw_lin``), minimum effort besides."""
    model = Model("block", gravity=(0.0, -9.81, 0.0))
    block = model.add_body("block", M, np.diag([0.01, 0.01, 0.01]), rotation="321")
    E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])
    model.add_constraint("rail.v2", ca.dot(E2, block.com.v), joint="rail", position=block.com.position[1])
    model.add_constraint("rail.v3", ca.dot(E3, block.com.v), joint="rail", position=block.com.position[2])
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"rail.w{k + 1}", ca.dot(E, block.omega), joint="rail")
    model.add_force("push", block.com, ca.vertcat(model.add_input("u"), 0, 0))
    ocp = OptimalControlProblem(model, t_final=T)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
    ocp.track("block.x", lambda t: ca.pw_lin(t, ca.DM(SAMPLES), ca.DM(VALUES)), weight=W)
    ocp.minimize_effort(["u"])
    return ocp


def pontryagin_solution():
    """``t -> (x, v, p1, p2)`` (4 x len(t)) of the block's optimum by ``solve_bvp`` (module notes)."""
    from scipy.integrate import solve_bvp

    def rhs(t, y):
        x, v, p1, p2 = y
        return np.vstack([v, -p2 / (2 * M * M), -2 * W * (x - np.interp(t, SAMPLES, VALUES)), -p1])

    mesh = np.linspace(0.0, T, 201)
    sol = solve_bvp(rhs, lambda a, b: np.array([a[0], a[1], b[2], b[3]]), mesh, np.zeros((4, mesh.size)), tol=1e-8,
                    max_nodes=100000)
    if sol.status != 0:
        raise RuntimeError(f"solve_bvp did not converge: {sol.message}")
    return sol.sol
