"""The full refinement message of one solve, and the history's points/estimates per refinement.

    python messages.py PROBLEM TOL
"""
import sys

import nc8

pr = nc8.build(sys.argv[1])
sol = pr.solve(tolerance=float(sys.argv[2]), progress=False)
r = sol.mesh_refinement
print(r["message"])
for h in r["history"]:
    print(h.get("refinement"), h.get("points"), h.get("estimate"), h.get("warm_retries"))
