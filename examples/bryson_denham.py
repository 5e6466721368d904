"""Bryson and Denham's state-constrained problem as a rigid body, solved to a tolerance.

A block of 1 kg on a rail (along E1; gravity along -E2 presses it on the rail) is pushed by
one input ``u``. It starts at x = 0 moving at +1 m/s and must be back at x = 0 moving at
-1 m/s after T = 1 s, never passing x = l = 1/9 m, with the least integral of u^2. The
bound is met along an arc in the middle of the motion: the push kinks where the block
reaches and leaves the wall (Bryson, Denham and Dreyfus 1963; Bryson and Ho, "Applied
Optimal Control", sec. 3.11). The solve asks for an error of at most 1e-4 (states in SI
units, loads relative to the largest) and says what it estimates it reached.

    python examples/bryson_denham.py [tolerance]
"""
import sys

import casadi as ca
import numpy as np

import ocp_constraints as oc

tolerance = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-4
wall = 1 / 9
model = oc.Model("bryson_denham", gravity=(0.0, -9.81, 0.0))
block = model.add_body("block", 1.0, np.diag([0.01, 0.01, 0.01]), rotation="321")
E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])
# The rail: the block's center moves along E1 only, and the block does not turn.
model.add_constraint("rail.v2", ca.dot(E2, block.com.v), joint="rail", position=block.com.position[1])
model.add_constraint("rail.v3", ca.dot(E3, block.com.v), joint="rail", position=block.com.position[2])
for k, E in enumerate((E1, E2, E3)):
    model.add_constraint(f"rail.w{k + 1}", ca.dot(E, block.omega), joint="rail")
u = model.add_input("u")
model.add_force("push", block.com, ca.vertcat(u, 0, 0))

ocp = oc.OptimalControlProblem(model, t_final=1.0)
ocp.initial({"block.x": 0.0, "block.vbar_x": 1.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
ocp.final({"block.x": 0.0, "block.vbar_x": -1.0})
ocp.bound("block.x", -1.0, wall)
ocp.minimize_effort(["u"])

sol = ocp.solve(tolerance=tolerance)
refinement = sol.mesh_refinement
print(refinement["message"])
print(f"objective {sol.objective:.9f}")
print(f"estimated error: states {refinement['estimate']['states']:.3e}, multipliers {refinement['estimate']['multipliers']:.3e}")
t = np.linspace(0.0, 1.0, 11)
print("t:", " ".join(f"{v:.1f}" for v in t))
print("x:", " ".join(f"{v:.12f}" for v in sol.interpolate("block.x", t)))
print("v:", " ".join(f"{v:.12f}" for v in sol.interpolate("block.vbar_x", t)))
print(f"largest rail force {np.abs(sol.loads()['rail.F_y']).max():.6f} N")
