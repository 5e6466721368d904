"""A wheel driven up a slope by its axle, rolling without slipping inside a friction cone.

The slope's frame is the fixed basis: E1 up the slope, E3 its normal (gravity tilted by the slope
angle). The wheel (a disk, axis E2) is kept in the E1-E3 plane and its contact point, the material
point at -R E3 from the center, has no velocity: both written by hand as ``pi = f . v + h . omega``
(paper eq. 25), so the toolkit derives the contact's normal and friction forces (eq. 26). From rest
to rest 1 m up the slope in 1.5 s, minimum integral of the axle torque squared, with the contact
force inside the friction cone mu = 0.6 (a path constraint on the contact load, by name). Only the
coordinates the problem is about get boundary values; the rest follow from the constraints.

    python examples/wheel_on_slope.py
"""
import math

import casadi as ca
import numpy as np

import ocp_constraints as oc

m, R, slope, mu = 2.0, 0.2, math.radians(20.0), 0.6
E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])
model = oc.Model("wheel", gravity=(-9.81 * math.sin(slope), 0.0, -9.81 * math.cos(slope)))
# "213": the first angle (psi) turns about E2, the rolling angle; theta and phi stay 0.
disk = model.add_body("disk", m, m * R**2 * np.diag([0.25, 0.5, 0.25]), rotation="213")
c = disk.com

# The plane of motion: no motion along E2, turning about E2 only.
model.add_constraint("plane.v2", ca.dot(E2, c.v), joint="plane", position=c.position[1])
model.add_constraint("plane.w1", ca.dot(E1, disk.omega), joint="plane")
model.add_constraint("plane.w3", ca.dot(E3, disk.omega), joint="plane")
# Rolling: the wheel's material point at the contact has no velocity (along the slope and normal).
v_contact = c.v + ca.cross(disk.omega, ca.DM([0.0, 0.0, -R]))
model.add_constraint("contact.t", ca.dot(E1, v_contact), joint="contact")
model.add_constraint("contact.n", ca.dot(E3, v_contact), joint="contact", position=c.position[2] - R)

axle = model.add_input("axle")
model.add_torque("axle", disk, ca.vertcat(0, axle, 0))

ocp = oc.OptimalControlProblem(model, t_final=1.5)
ocp.initial({"disk.x": 0.0, "disk.psi": 0.0, "disk.theta": 0.0, "disk.phi": 0.0, "disk.vbar_x": 0.0})
ocp.final({"disk.x": 1.0, "disk.vbar_x": 0.0})
ocp.minimize_effort()
ocp.friction_cone("contact", mu, normal=(0, 0, 1))   # N >= 0 and |F_t| <= mu N on the contact's load

sol = ocp.solve(oc.Radau(20, degree=3))
loads = sol.loads()
ratio = np.abs(loads["contact.F_x"]) / loads["contact.F_z"]
print(f"{sol.status} in {sol.iterations} iterations, objective {sol.objective:.10f}")
print(f"largest friction force {np.abs(loads['contact.F_x']).max():.6f} N, "
      f"largest |F_t|/N {ratio.max():.6f} (mu = {mu}), normal force {loads['contact.F_z'].min():.6f} N")
