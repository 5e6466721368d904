"""A robot arm from its URDF: every joint's constraint force and moment, and an optimal motion
with a bound on one joint's reaction force.

    pip install -e ".[urdf]"            # yourdfpy; the UR5 below comes with example-robot-data
    python examples/robot_arm_urdf.py [--urdf PATH] [--intervals N] [--out DIR]

1. ``oc.load_urdf``: links become bodies, joints the joint library's joints (revolute about the
   URDF axis here), each with an actuator input ``<joint>.tau``.
2. Inverse dynamics along a joint motion: each joint's constraint force ``F_c`` and moment ``M_c``
   (Lagrange's prescription, paper eq. 26) and each motor's torque (tests/test_urdf.py checks
   them against Pinocchio's RNEA).
3. Minimum effort point to point in 1 s, rest to rest, within the URDF's effort and speed
   limits; then again with ``|F_c| <= 0.9 x`` the first optimum's peak at the shoulder lift
   joint: the bound holds (active), at a higher effort.
"""
from __future__ import annotations

import argparse
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import casadi as ca
import numpy as np

import ocp_constraints as oc


def default_urdf() -> Path:
    try:
        root = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    except PackageNotFoundError:
        raise SystemExit("give --urdf PATH (or pip install example-robot-data for the UR5 used by default)") from None
    return root / "ur_description/urdf/ur5_robot.urdf"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--urdf", type=Path, default=None, help="URDF file (default: the UR5 of example-robot-data)")
    ap.add_argument("--intervals", type=int, default=10, help="Radau intervals of the optimal-control problems")
    ap.add_argument("--out", default=None, help="folder for the bounded optimum's results (CSV, .sto, plots, report.html)")
    args = ap.parse_args()
    path = args.urdf or default_urdf()

    # 1. the model (base_link, fixed to the world by the URDF, becomes the ground: base="ground")
    robot = oc.load_urdf(path, base="ground")
    print(f"{robot.model.name}: {len(robot.model.bodies)} bodies, joints {', '.join(robot.joint_names)}")

    # 2. inverse dynamics along a smooth motion of every joint
    t = np.linspace(0.0, 2.0, 41)[:, None]
    w = np.linspace(0.6, 1.6, len(robot.joint_names))
    q, qd, qdd = 0.6 * np.sin(w * t), 0.6 * w * np.cos(w * t), -0.6 * w**2 * np.sin(w * t)
    ident = oc.InverseDynamics(oc.SystemEquations(robot.model)).solve(t.ravel(), *robot.body_states(q, qd, qdd))
    loads = ident.loads()
    for j in robot.joint_names:
        prefix = next(p for p in (j, f"{j}@{robot.joints[j].child}") if f"{p}.F_x" in loads)
        F = np.sqrt(sum(loads[f"{prefix}.F_{a}"] ** 2 for a in "xyz"))
        M = np.sqrt(sum(loads[f"{prefix}.M_{a}"] ** 2 for a in "xyz"))
        print(f"  {j:22s} max |F_c| = {F.max():8.2f} N   max |M_c| = {M.max():7.2f} N m   "
              f"max |tau| = {np.abs(ident.input(robot.joints[j].input)).max():7.2f} N m")

    # 3. minimum effort, rest to rest, effort and speed limits; then a bound on a joint reaction
    qa, qb = np.array([0.0, -1.2, 1.4, -0.2, 0.0, 0.0]), np.array([0.8, -0.4, 0.6, -0.2, 0.0, 0.0])
    channel = "shoulder_lift_joint@upper_arm_link"

    def solve(force_bound: float | None):
        problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
        robot.set_boundary(problem, "initial", qa)
        robot.set_boundary(problem, "final", qb)
        robot.set_guess(problem, lambda s: qa + (qb - qa) * (3 * np.clip(s, 0, 1) ** 2 - 2 * np.clip(s, 0, 1) ** 3)[:, None])
        robot.apply_limits(problem)
        problem.minimize_effort()
        if force_bound is not None:
            F = problem.joint_force(channel)
            problem.subject_to(ca.dot(F, F), -np.inf, force_bound**2, f"|F_c| at {channel}")
        sol = problem.solve(oc.Radau(args.intervals, degree=3), {"ipopt.print_level": 0, "print_time": False})
        L = sol.loads()
        return problem, sol, np.sqrt(sum(L[f"{channel}.F_{a}"] ** 2 for a in "xyz")).max()

    _, free, peak = solve(None)
    print(f"minimum effort: objective {free.objective:.4f} N^2 m^2 s, peak |F_c| at {channel} {peak:.2f} N "
          f"({free.iterations} IPOPT iterations)")
    problem, bounded, peak_b = solve(0.9 * peak)
    print(f"with |F_c| <= {0.9 * peak:.2f} N: objective {bounded.objective:.4f} N^2 m^2 s, peak |F_c| {peak_b:.2f} N "
          f"({bounded.iterations} IPOPT iterations)")
    if args.out:
        from ocp_constraints.scenes.tasks import write_trajectory_results

        summary = {"scene": robot.model.name, "task": "minimum effort with a joint reaction bound",
                   "success": bounded.success, "status": bounded.status, "objective": bounded.objective,
                   "joints": [ch.prefix for ch in problem.eqs.load_channels]}
        inputs = {n: bounded.sample(n) for n in robot.model.inputs}
        write_trajectory_results(args.out, bounded.trajectory, summary, inputs, plots=True)
        print(f"results written to {args.out}")


if __name__ == "__main__":
    main()
