"""Convergence of the pendulum swing-up (issue 3): objective and multiplier errors
against a fine Radau (degree 5, N = 160) solution, for each scheme and N.

Run: python scripts/ocp_convergence.py
"""
import numpy as np

from ocp_constraints.scenes.registry import build_task
from ocp_constraints.ocp.schemes import HermiteSimpson, Radau, Trapezoidal

_, problem = build_task("pendulum", "swing_up")
reference = problem.solve(Radau(160, degree=5))
names = problem.eqs.constraint_names
t = np.linspace(0.05, 1.95, 77)  # inside the horizon: Radau has no multiplier variable of its own at t0
lam_ref = np.array([reference.interpolate(f"{n}.lambda", t) for n in names])
scale = np.abs(lam_ref).max()
print(f"reference objective {reference.objective:.12f}")
print(f"{'scheme':16s} {'N':>4s} {'objective error':>16s} {'order':>6s} {'lambda error':>13s} {'order':>6s} {'iter':>5s} {'solve s':>8s}")
for make in (Trapezoidal, HermiteSimpson, lambda n: Radau(n, degree=1), lambda n: Radau(n, degree=2),
             lambda n: Radau(n, degree=3), lambda n: Radau(n, degree=4)):
    previous = None
    for n in (10, 20, 40, 80):
        sol = problem.solve(make(n))
        ej = abs(sol.objective - reference.objective)
        el = np.abs(np.array([sol.interpolate(f"{c}.lambda", t) for c in names]) - lam_ref).max() / scale
        orders = ("", "") if previous is None else (f"{np.log2(previous[0] / ej):.2f}", f"{np.log2(previous[1] / el):.2f}")
        print(f"{sol.transcription.scheme.label:16s} {n:4d} {ej:16.3e} {orders[0]:>6s} {el:13.3e} {orders[1]:>6s} "
              f"{sol.iterations:5d} {sol.wall_time['solve']:8.3f}")
        previous = (ej, el)
