"""The whole mesh_refinement record of one refined solve (history entries' scalar fields; arrays summarised):

    python diag.py NAME TOL [--eps E]  > diag_NAME_TOL_EPS.txt 2>&1   (under ulimit -t 200, timeout -s KILL 290;
    stderr kept: CasADi's warnings)
"""
import json
import sys

import numpy as np

import models

args = sys.argv[1:]
eps = None
if "--eps" in args:
    i = args.index("--eps"); eps = float(args[i + 1]); del args[i:i + 2]
pb, P = models.build(args[0], eps)
sol = pb.solve(tolerance=float(args[1]))
mr = sol.mesh_refinement


def short(v):
    if isinstance(v, (list, tuple, np.ndarray)) and len(v) > 8 and not isinstance(v[0], dict):
        return f"<{len(v)} values>"
    return v


import run
print("library:", run.library_id())
print("record keys:", sorted(mr))
for k, v in mr.items():
    if k not in ("history", "mesh", "degrees", "message"):
        print(f"{k}: {json.dumps(short(v), default=str)[:600]}")
print("message:", mr["message"])
for i, h in enumerate(mr["history"]):
    print(i, json.dumps({k: short(v) for k, v in h.items()}, default=str)[:1500])
