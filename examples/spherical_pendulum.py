"""A 3-D pendulum on a ball joint written by hand, turned by three motor torques to a target orientation.

A rod (1 kg, 1 m) hangs from its top end P, which stays at the origin: three constraints
``E_k . v_P = 0`` with their position forms (paper eq. 25 with ``h = 0``); the toolkit derives the
ball joint's force at P (eq. 26, no moment). Torques about E1, E2, E3 (fixed basis) turn it from
hanging at rest to rest at the 3-2-1 angles (0.6, 0.4, 0.9) rad in 2 s, minimum integral of the
torques squared. The center's coordinates are left to the constraints.

    python examples/spherical_pendulum.py
"""
import casadi as ca
import numpy as np

import ocp_constraints as oc

m, L = 1.0, 1.0
model = oc.Model("spherical", gravity=(0.0, 0.0, -9.81))
bob = model.add_body("bob", m, np.diag([m * L**2 / 12, m * L**2 / 12, 0.01]), rotation="321")
P = bob.point("P", (0.0, 0.0, L / 2))                # the rod's top end, body basis from the center
for k in range(3):                                   # the ball joint: P does not move
    E = ca.DM.eye(3)[:, k]
    model.add_constraint(f"ball.v{k + 1}", ca.dot(E, P.v), joint="ball", position=P.position[k])
torques = [model.add_input(f"t{c}") for c in "xyz"]
model.add_torque("motor", bob, ca.vertcat(*torques))

ocp = oc.OptimalControlProblem(model, t_final=2.0)
rest = {"bob.omega_x": 0.0, "bob.omega_y": 0.0, "bob.omega_z": 0.0}
ocp.initial({"bob.psi": 0.0, "bob.theta": 0.0, "bob.phi": 0.0, **rest})
ocp.final({"bob.psi": 0.6, "bob.theta": 0.4, "bob.phi": 0.9, **rest})
ocp.minimize_effort()

sol = ocp.solve(oc.Radau(20, degree=3))
force = np.linalg.norm(np.column_stack([sol.loads()[f"ball.F_{a}"] for a in "xyz"]), axis=1)
print(f"{sol.status} in {sol.iterations} iterations, objective {sol.objective:.10f}")
print(f"ball joint force: largest {force.max():.6f} N, at the start {force[0]:.6f} N")
