"""Minimum-effort swing-up of a rod on a revolute joint, with its hinge loads.

Run: python examples/swing_up.py
The built-in task does the same: ocp-constraints solve pendulum --task swing_up
"""
import math

import casadi as ca
import numpy as np

from ocp_constraints import joints, Model, OptimalControlProblem, Radau  # or Trapezoidal(N), HermiteSimpson(N)

# A uniform rod (1 kg, 1 m) hinged at one end at the origin, swinging in the E1-E2 plane.
model = Model("rod", gravity=(0.0, -9.81, 0.0))
rod = model.add_body("rod", 1.0, np.diag([1 / 12, 0.0, 1 / 12]), rotation="321")
joints.revolute(model, "hinge", rod.point("A", [0.0, 0.5, 0.0]), axis=(0, 0, 1))
torque = model.add_input("motor")
model.add_torque("motor", rod, ca.vertcat(0, 0, torque))

ocp = OptimalControlProblem(model, t_final=2.0)
ocp.bound("motor", -20.0, 20.0)
ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})  # hanging at rest
ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})  # upright at rest
ocp.minimize_effort(["motor"])  # int torque^2 dt
ocp.set_guess("rod.psi", lambda t: math.pi * t / 2 - np.sin(math.pi * t / 2))  # swing back first

sol = ocp.solve(Radau(30, degree=3))
print(f"{sol.status}: objective {sol.objective:.6f} N^2 m^2 s after {sol.iterations} iterations")
loads = sol.loads()  # hinge.F_x..z (N), hinge.M_x..z (N m), hinge.power, and every lambda
print(f"peak hinge force {np.hypot(loads['hinge.F_x'], loads['hinge.F_y']).max():.3f} N, "
      f"peak motor torque {np.abs(sol.sample('motor')).max():.3f} N m")
print(f"constraint residuals (position, velocity): {sol.residuals()}")

# Mesh refinement: start a finer (or another) transcription from this solution.
fine = ocp.solve(Radau(120, degree=3), warm_start=sol)
print(f"refined to N = 120: objective {fine.objective:.9f} after {fine.iterations} iterations")
