"""Swing a rod toward a target angle as closely as the effort allows: a terminal (Mayer) cost.

A rod (1 kg, 0.8 m) hangs from a hinge at its end; a motor at the hinge swings it in 1.5 s from rest toward 120 degrees.
Reaching the target exactly is not required: the objective is the effort, int tau^2 dt, plus w (psi(T) - target)^2
at the final time (``minimize_terminal``). The hinge's reaction force along the way is a result, as ever.

    python examples/terminal_target.py
"""
import math

import casadi as ca
import numpy as np

import ocp_constraints as oc

M, L, G, T = 1.0, 0.8, 9.81, 1.5          # kg, m, m/s^2, s
TARGET, W = math.radians(120.0), 20.0      # rad, weight of the miss (per rad^2)

model = oc.Model("rod_to_target", gravity=(0.0, -G, 0.0))
rod = model.add_body("rod", M, M * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))

problem = oc.OptimalControlProblem(model, t_final=T)
problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
problem.minimize_effort(["motor"])
problem.minimize_terminal(W * (problem.quantity("rod.psi") - TARGET) ** 2, label="miss")

sol = problem.solve(tolerance=1e-6)
psi_T = float(sol.sample("rod.psi")[-1])
force = np.hypot(sol.sample("hinge.v1.lambda"), sol.sample("hinge.v2.lambda"))
print(sol.mesh_refinement["message"])
print(f"final angle: {math.degrees(psi_T):.6f} deg (target {math.degrees(TARGET):.1f})")
print(f"objective: {sol.objective:.9f}")
print(f"largest hinge force: {force.max():.4f} N; at the end: {force[-1]:.6f} N")
