"""Turn a rod with a torque-limited motor, to a tolerance: an input bound that is reached.

A rod (0.8 kg, 0.6 m) turns about a hinge at its end, in a horizontal plane (no gravity), from rest to rest
through 1.2 rad in 0.8 s, with least effort int tau^2 dt. The motor gives at most 0.9 N m, less than the
unbounded optimum asks (1.08 N m at the ends), so the torque sits on its bound at the start and the end and
leaves it at two junctions. ``solve(tolerance=1e-4)`` refines the mesh until the estimated error of the motion
and of the hinge force (relative to the largest) is at most 1e-4; ``mesh_refinement`` says how it went.

    python examples/torque_limited_rod.py
"""
import casadi as ca
import numpy as np

import ocp_constraints as oc

M, L, T, THETA, TAU_MAX = 0.8, 0.6, 0.8, 1.2, 0.9       # kg, m, s, rad, N m

model = oc.Model("torque_limited_rod", gravity=(0.0, 0.0, 0.0))
rod = model.add_body("rod", M, M * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))

problem = oc.OptimalControlProblem(model, t_final=T)
problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
problem.final({"rod.psi": THETA, "rod.psi_dot": 0.0})
problem.bound("motor", -TAU_MAX, TAU_MAX)
problem.minimize_effort(["motor"])

if __name__ == "__main__":       # the problem alone where another script loads this one (runpy)
    sol = problem.solve(tolerance=1e-4)
    record = sol.mesh_refinement
    print(record["message"])
    print(f"estimate: states {record['estimate']['states']:.1e}, hinge force {record['estimate']['multipliers']:.1e} "
          f"(of the largest)")
    print(f"objective: {sol.objective:.9f}")
    times = np.array([0.05, 0.2, 0.4, 0.6, 0.75])     # s
    force = np.hypot(sol.interpolate("hinge.v1.lambda", times), sol.interpolate("hinge.v2.lambda", times))
    for t, tau, f in zip(times, sol.interpolate("motor", times), force):
        print(f"t = {t:.2f} s: torque {tau:+.6f} N m, hinge force {f:.6f} N")
