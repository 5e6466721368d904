"""The whirling body of paper sec. 3.4, written constraint by constraint.

Run: python examples/whirling_by_hand.py
The built-in scene `problems/whirling.py` does the same with the joint library.
"""
import casadi as ca
import numpy as np

from ocp_constraints import consistent_state, EulerSequence, Model, simulate, SystemEquations

model = Model("whirling", gravity=(0, 0, -9.81))
body = model.add_body(
    "body", mass=1.2,
    inertia=[[0.040, 0.003, 0.006], [0.003, 0.020, -0.005], [0.006, -0.005, 0.050]],
    rotation="313",  # or "321", any Euler sequence, or "quaternion"
)
com = np.array([0.08, -0.45, 0.06])  # center of mass seen from X_A, body basis
A = body.point("A", -com)  # X_A, given by its offset from the center of mass
g1, g2, g3 = body.dual_euler_basis()  # g^1, g^2, g^3 (paper eq. 11)

# E_k . v_A = 0: X_A stays at the origin. `position` is the holonomic form phi(q) = 0.
for k in range(3):
    model.add_constraint(f"shaft.v{k + 1}", A.v[k], joint="shaft", position=A.position[k])
Omega = 2 + 0.5 * ca.sin(model.t)
model.add_constraint("shaft.drive", ca.dot(g1, body.omega) - Omega, joint="shaft")  # the motor
model.add_constraint("shaft.lock", ca.dot(g3, body.omega), joint="shaft")

theta0 = np.pi / 2 + 0.5
xbar = np.asarray(EulerSequence("313").rotation([0, theta0, 0])) @ com
coordinates = {"body.x": xbar[0], "body.y": xbar[1], "body.z": xbar[2], "body.psi": 0.0, "body.theta": theta0, "body.phi": 0.0}

eqs = SystemEquations(model)
q0, u0 = consistent_state(eqs, coordinates, {"body.theta_dot": 0.0})  # psi_dot, vbar follow
traj = simulate(eqs, q0, u0, t_final=5.0)

torque = traj.sample("shaft.drive.lambda")  # lambda_4: the motor torque (N m)
loads = traj.loads()  # shaft.F_x..z at X_A, shaft.M_x..z, shaft.power
print(f"peak motor torque {np.abs(torque).max():.4f} N m, peak power {np.abs(loads['shaft.power']).max():.4f} W")
print(f"energy put in by the motor over 5 s: {traj.work[-1].sum():.6f} J")
