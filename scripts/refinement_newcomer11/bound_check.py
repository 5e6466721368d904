"""Does the refined solution hold its bound on a dense grid?  python bound_check.py NAME TOL [--start N DEG]"""
import sys

import numpy as np

import models
import ocp_constraints as oc

name, tol = sys.argv[1], float(sys.argv[2])
pb, P = models.build(name)
if "--start" in sys.argv:
    i = sys.argv.index("--start")
    sol = pb.solve(oc.Radau(int(sys.argv[i + 1]), degree=int(sys.argv[i + 2])), tolerance=tol)
else:
    sol = pb.solve(tolerance=tol)
T = P["T"]
t = np.linspace(0, T, 200001)
q, b = {"cart_force": ("pivot.v1.lambda", P.get("Fx_max")), "arm_sat": ("tau1", P.get("tau1_max")),
        "rod_lower": ("motor", P.get("tau_low"))}[name]
v = np.asarray(sol.interpolate(q, t))
print(name, tol, "J", repr(sol.objective), f"max {q} {v.max():.12f} min {v.min():.12f} bound {b}",
      "excess", max(v.max() - b, -b - v.min()) if name != "rod_lower" else (-b - v.min()))
