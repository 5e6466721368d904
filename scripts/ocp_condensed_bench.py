"""Condensed maximal transcription (issue 13, 1b) against the maximal form, joint coordinates and rockit.

    python scripts/ocp_condensed_bench.py [PROBLEM ...] [--intervals 20] [--runs 1] [--no-rockit]
    python scripts/ocp_condensed_bench.py --accuracy 10 20 40 80

Problems: ``textbook`` (the issue's cart-pole: two bodies on 3-2-1 angles, rail and hinge written as
constraints, one push, min int u^2, rest to rest), ``pendulum`` (the swing-up with its hinge written
by hand), and the suite's ``four_bar`` (loop closure), ``rolling_disk`` (friction cone) and
``quadrotor_load``. Forms: ``maximal``; ``condensed`` (slacks at mesh points, the default of
coordinates="condensed"); ``condensed-points`` (slacks at every point: the maximal NLP with its
accelerations and multipliers eliminated, so its optimum must equal the maximal one on the same
mesh); ``joint`` where joint coordinates apply; rockit (minimal coordinates, Radau of the same
degree and N). Per row: success, IPOPT iterations, objective, CPU seconds from building the NLP to
the solution, IPOPT's own CPU seconds (t_proc_total), wall seconds, and against the maximal form's
solution on the same mesh the largest difference of states and of multipliers (relative to the
largest multiplier). Medians of --runs.

``--accuracy N ...``: the swing-up with its hinge by hand, per N and form (maximal, condensed), the
errors against the Pontryagin extremal (bench/references.py: objective; largest error of psi and of
the torque at 101 times),
the largest position- and velocity-level constraint residuals over all collocation points (the
condensed form imposes them at the mesh points only: between, this is its drift) and the CPU time.
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

import casadi as ca
import numpy as np

import ocp_constraints as oc
from ocp_constraints.bench import ocp_suite as planar, ocp_suite_3d as spatial
from ocp_constraints.bench import ocp_suite_minimal as minimal, ocp_suite_minimal_3d as minimal3d
from ocp_constraints.ocp.condensed_transcription import CondensedTranscription
from ocp_constraints.ocp.transcription import Transcription

E = [ca.DM.eye(3)[:, k] for k in range(3)]


def textbook(coordinates: str = "maximal", radius: float = 0.0) -> oc.OptimalControlProblem:
    """The issue's textbook problem written from scratch: cart on a rail, pole on a hinge, by hand.
    ``radius``: the pole a solid cylinder of that radius (regular inertia) instead of a thin rod."""
    model = oc.Model("cart_pole", gravity=(0.0, -9.81, 0.0))
    cart = model.add_body("cart", 1.0, np.diag([0.01, 0.01, 0.01]), rotation="321")
    pole = model.add_body("pole", 0.5, 0.5 / 12 * np.diag([1.0, 0.0, 1.0]) + 0.5 * radius**2 * np.diag([0.25, 0.5, 0.25]),
                          rotation="321")
    model.add_constraint("rail.v2", ca.dot(E[1], cart.com.v), joint="rail", position=cart.com.position[1])
    model.add_constraint("rail.v3", ca.dot(E[2], cart.com.v), joint="rail", position=cart.com.position[2])
    for k in range(3):
        model.add_constraint(f"rail.w{k + 1}", ca.dot(E[k], cart.omega), joint="rail")
    A = pole.point("A", (0.0, 0.5, 0.0))
    for k in range(3):
        model.add_constraint(f"hinge.v{k + 1}", ca.dot(E[k], A.v - cart.com.v), joint="hinge",
                             position=A.position[k] - cart.com.position[k])
    for k in range(2):
        model.add_constraint(f"hinge.w{k + 1}", ca.dot(E[k], pole.omega - cart.omega), joint="hinge")
    push = model.add_input("push")
    model.add_force("push", cart.com, ca.vertcat(push, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=2.0, coordinates=coordinates)
    zero = {f"{b}.{a}": 0.0 for b in ("cart", "pole") for a in ("psi", "theta", "phi") if (b, a) != ("pole", "psi")}
    ocp.initial({"cart.x": 0.0, "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.omega_z": 0.0, **zero})
    ocp.final({"cart.x": 0.0, "pole.psi": math.pi, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    ocp.bound("push", -40.0, 40.0)
    ocp.minimize_effort(["push"])
    return ocp


def textbook_minimal(radius: float = 0.0) -> minimal.Minimal:
    """The same in (x, psi) by Lagrange's equations: pole center at (x + sin psi / 2, -cos psi / 2)."""
    q, qd, f = ca.SX.sym("q", 2), ca.SX.sym("qd", 2), ca.SX.sym("f")
    c = ca.vertcat(q[0] + 0.5 * ca.sin(q[1]), -0.5 * ca.cos(q[1]))
    v = ca.jacobian(c, q) @ qd
    T = 0.5 * 1.0 * qd[0] ** 2 + 0.5 * 0.5 * ca.dot(v, v) + 0.5 * (0.5 / 12 + 0.5 * radius**2 / 4) * qd[1] ** 2
    dyn = minimal.lagrange(q, qd, T, 0.5 * 9.81 * c[1], f * qd[0])
    return minimal._minimal("textbook", dyn, f, f**2, 2.0, [0.0] * 4, [0.0, math.pi, 0.0, 0.0], [(-40.0, 40.0)])


def pendulum(coordinates: str = "maximal", radius: float = 0.0) -> oc.OptimalControlProblem:
    """The swing-up of problems/pendulum.py (planar rod, motor about E3) with the hinge written by hand.
    ``radius``: the rod a solid cylinder of that radius (regular inertia) instead of a thin rod."""
    model = oc.Model("pendulum", gravity=(0.0, -9.81, 0.0))
    d = np.array([0.0, -1.0, 0.0])
    J = 1.0 / 12 * (np.eye(3) - np.outer(d, d)) + radius**2 * (np.eye(3) / 4 + np.outer(d, d) / 4)
    rod = model.add_body("rod", 1.0, J, rotation="321")
    A = rod.point("A", -0.5 * d)
    for k in range(3):
        model.add_constraint(f"hinge.v{k + 1}", ca.dot(E[k], A.v), joint="hinge", position=A.position[k])
    for k in range(2):
        model.add_constraint(f"hinge.w{k + 1}", ca.dot(E[k], rod.omega), joint="hinge")
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    ocp = oc.OptimalControlProblem(model, t_final=2.0, coordinates=coordinates)
    ocp.bound("motor", -20.0, 20.0)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0, "rod.theta": 0.0, "rod.phi": 0.0})
    ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    ocp.set_guess("rod.psi", lambda t: math.pi * t / 2 - np.sin(math.pi * t / 2))
    return ocp


def pendulum_minimal(radius: float = 0.0) -> minimal.Minimal:
    q, qd, tau = ca.SX.sym("q", 1), ca.SX.sym("qd", 1), ca.SX.sym("tau")
    dyn = minimal.lagrange(q, qd, 0.5 * (1.0 / 3 + radius**2 / 4) * qd[0] ** 2, -9.81 * 0.5 * ca.cos(q[0]), tau * qd[0])
    return minimal._minimal("pendulum", dyn, tau, tau**2, 2.0, [0.0, 0.0], [math.pi, 0.0], [(-20.0, 20.0)],
                            guesses={0: lambda t: math.pi * t / 2 - ca.sin(math.pi * t / 2)})


THICK = 0.05     # m: the regular-inertia variants' radius


def scene_task(scene: str, task: str):
    """A built-in scene's task (problems/*.py), its problem made with the given coordinates."""
    from ocp_constraints.scenes.registry import load_scene_module, resolve_parameters

    def build(coordinates: str) -> oc.OptimalControlProblem:
        module = load_scene_module(scene)
        problem = module.TASKS[task](resolve_parameters(scene, module.DEFAULTS, {}))
        problem.coordinates = coordinates
        return problem

    return build


PROBLEMS = {"textbook": (textbook, textbook_minimal), "pendulum": (pendulum, pendulum_minimal),
            "textbook_thick": (lambda c: textbook(c, THICK), lambda: textbook_minimal(THICK)),
            "pendulum_thick": (lambda c: pendulum(c, THICK), lambda: pendulum_minimal(THICK)),
            "four_bar": (planar.four_bar, minimal.four_bar), "rolling_disk": (spatial.rolling_disk, minimal3d.rolling_disk),
            "quadrotor_load": (spatial.quadrotor_load, minimal3d.quadrotor_load),
            "walker": (spatial.walker, minimal3d.walker),
            "ball_socket_reach": (scene_task("ball_socket", "reach"), None),
            "rolling_disk_drive": (scene_task("rolling_disk", "drive"), None)}
FORMS = {"maximal": lambda pr, m: Transcription(pr, m),
         "condensed": lambda pr, m: CondensedTranscription(pr, m, "mesh"),
         "condensed-points": lambda pr, m: CondensedTranscription(pr, m, "points")}


def ours(build, form: str, N: int) -> tuple[dict, object]:
    cpu, wall = time.process_time(), time.perf_counter()
    problem = build("auto" if form == "joint" else "maximal")
    if form == "joint" and problem.nlp_coordinates != "joint":
        return {}, None
    tr = problem.transcription(oc.Radau(N, degree=3)) if form == "joint" else FORMS[form](problem, oc.Radau(N, degree=3))
    try:
        sol = tr.solve({"record_time": True})
    except oc.OCPSolveError as err:
        sol = err.solution
    return {"success": sol.success, "iterations": sol.iterations, "objective": sol.objective,
            "cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
            "ipopt_cpu": float(sol.stats.get("t_proc_total", float("nan")))}, sol


def rockit(mk, N: int) -> dict:
    from ocp_constraints.bench.ocp_suite_peers import solve_rockit

    cpu = time.process_time()
    r = solve_rockit(mk(), N, degree=3)
    return {"success": r["success"], "iterations": r["iterations"], "objective": r["objective"],
            "cpu": time.process_time() - cpu, "wall": r["solve_s"], "ipopt_cpu": r["ipopt_s"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("problems", nargs="*", default=list(PROBLEMS))
    ap.add_argument("--intervals", type=int, default=20)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--forms", nargs="+", default=[*FORMS, "joint"])
    ap.add_argument("--no-rockit", action="store_true")
    ap.add_argument("--accuracy", type=int, nargs="+", metavar="N")
    args = ap.parse_args()
    if args.accuracy:
        accuracy(args.accuracy)
        return
    print(f"Radau 3, N = {args.intervals}, medians of {args.runs}")
    print("| problem | form | success | iterations | objective | CPU s | IPOPT CPU s | wall s | max dX vs maximal "
          "| max dlambda / max lambda vs maximal |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.problems:
        build, mk = PROBLEMS[name]
        reference = None
        for form in args.forms:
            rows, sol = [], None
            for _ in range(args.runs):
                row, sol = ours(build, form, args.intervals)
                rows.append(row)
            if sol is None:
                print(f"| {name} | {form} | (joint coordinates do not apply) |||||||", flush=True)
                continue
            if form == "maximal":
                reference = sol
            dx = dl = float("nan")
            if reference is not None and sol.X.shape == reference.X.shape:
                dx = float(np.abs(sol.X - reference.X).max())
                dl = float(np.abs(sol.lam - reference.lam).max() / max(np.abs(reference.lam).max(), 1e-300))
            print(_row(name, form, rows, f" {dx:.1e} | {dl:.1e} |"), flush=True)
        if not args.no_rockit and mk is not None:
            print(_row(name, "rockit (minimal)", [rockit(mk, args.intervals) for _ in range(args.runs)], " | |"), flush=True)


def accuracy(Ns: list[int]) -> None:
    """The swing-up with its hinge by hand against the Pontryagin extremal (bench/references.py)."""
    from ocp_constraints.bench.references import swing_up_reference

    ref = swing_up_reference()
    t = np.linspace(0.0, 2.0, 101)
    psi_ref, tau_ref = ref.states(t)[0], ref.torque(t)
    print(f"pendulum (hinge by hand): Pontryagin reference, objective {ref.objective:.12g}")
    print("| N | form | iterations | objective error | psi error | torque error | position residual | "
          "velocity residual | CPU s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for N in Ns:
        for form in ("maximal", "condensed"):
            cpu = time.process_time()
            sol = FORMS[form](pendulum("maximal"), oc.Radau(N, degree=3)).solve({})
            cpu = time.process_time() - cpu
            pos, vel = sol.residuals()
            print(f"| {N} | {form} | {sol.iterations} | {abs(sol.objective - ref.objective):.1e} | "
                  f"{np.abs(sol.interpolate('rod.psi', t) - psi_ref).max():.1e} | "
                  f"{np.abs(sol.interpolate('motor', t) - tau_ref).max():.1e} | {pos:.1e} | {vel:.1e} | {cpu:.2f} |",
                  flush=True)


def _row(name: str, form: str, rows: list[dict], tail: str) -> str:
    med = {k: statistics.median(r[k] for r in rows) for k in ("cpu", "ipopt_cpu", "wall")}
    r = rows[-1]
    return (f"| {name} | {form} | {r['success']} | {r['iterations']} | {r['objective']:.10g} | {med['cpu']:.2f} | "
            f"{med['ipopt_cpu']:.2f} | {med['wall']:.2f} |{tail}")


if __name__ == "__main__":
    main()
