"""The refinement history of one solve: mesh, objective, estimate per solve (python history.py PROBLEM TOL)."""
import json, sys
import numpy as np
import models as M

pr = M.build(sys.argv[1])
sol = pr.solve(tolerance=float(sys.argv[2]))
mr = sol.mesh_refinement
print("met", mr["met"], "objective", sol.objective)
for i, h in enumerate(mr["history"]):
    keep = {k: h.get(k) for k in ("points", "intervals", "objective", "estimate", "judged_against", "resolved",
                                  "objective_change", "iterations", "solves", "cpu", "warm_retries")}
    print(i, json.dumps(keep, default=lambda v: float(v) if np.isscalar(v) else str(v))[:600])
print(sorted(mr.keys()))
