"""pend at 3e-5: which solution does the stalled refinement return? Points of the returned solution, its mesh, the
record's estimate and "returned_refinement", against the message.

    python stall_check.py [TOL]
"""
import sys

import numpy as np

import nc8

tol = float(sys.argv[1]) if len(sys.argv) > 1 else 3e-5
sol = nc8.build("pend").solve(tolerance=tol, progress=False)
r = sol.mesh_refinement
print("message:", r["message"])
print("met", r["met"], "returned_refinement", r.get("returned_refinement"), "estimate", r["estimate"])
print("record's mesh intervals", len(r["mesh"]) - 1, "points in the returned solution", np.size(sol.t),
      "transcription intervals", sol.transcription.scheme.intervals)
for h in r["history"]:
    print("  refinement", h.get("refinement"), "intervals", h.get("intervals"), "points", h.get("points"),
          "estimate", h.get("estimate"))
