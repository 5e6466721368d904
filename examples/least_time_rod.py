"""Turn a rod in least time with a torque-limited motor: a bang-bang input, its switch found to a tolerance.

A rod (0.8 kg, 0.6 m) turns about a hinge at its end, in a horizontal plane (no gravity), from rest to rest through
1.2 rad as fast as a motor of at most 0.9 N m allows. The torque is on its upper bound, then on its lower one: one
jump, which the refinement makes a mesh point whose time is the optimizer's (``mesh_refinement["input_arcs"]`` gives
the arcs and their times). The hinge force, the constraint force this example is after, jumps there too.

    python examples/least_time_rod.py
"""
import casadi as ca
import numpy as np

import ocp_constraints as oc

M, L, THETA, TAU_MAX, TAU_BRAKE = 0.8, 0.6, 1.2, 0.9, 0.5       # kg, m, rad, N m, N m

model = oc.Model("least_time_rod", gravity=(0.0, 0.0, 0.0))
rod = model.add_body("rod", M, M * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))

problem = oc.OptimalControlProblem(model, t_final=1.0, t_final_bounds=(0.1, 5.0))
problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
problem.final({"rod.psi": THETA, "rod.psi_dot": 0.0})
problem.bound("motor", -TAU_BRAKE, TAU_MAX)
problem.minimize_final_time()

if __name__ == "__main__":       # the problem alone where another script loads this one (runpy)
    sol = problem.solve(tolerance=1e-6)
    record = sol.mesh_refinement
    print(record["message"])
    print(f"final time: {sol.t_final:.12f} s")
    for arc in record.get("input_arcs") or []:     # none where the first mesh already met the tolerance
        print(f"motor at {arc['value']:+.1f} N m from {arc['start']:.12f} s to {arc['end']:.12f} s")
    times = np.array([0.1, 0.3, 0.5, 0.7, 0.9]) * sol.t_final     # s
    force = np.hypot(sol.interpolate("hinge.v1.lambda", times), sol.interpolate("hinge.v2.lambda", times))
    for t, f in zip(times, force):
        print(f"t = {t:.6f} s: hinge force {f:.9f} N")
