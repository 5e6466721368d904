"""The refinement history of one solve: python history.py PROBLEM TOL  (PROBLEM as nc7.py, e.g. urdf_arm, load_arm)"""
import sys, time, json
import numpy as np
import models as M, ocp_constraints as oc
name, _, start = sys.argv[1].partition("@")
method = None
if start:
    d, n_ = start[1:].split("n"); method = oc.Radau(int(n_), degree=int(d))
pr = M.build(name)
c0 = time.process_time()
try:
    s = pr.solve(method, tolerance=float(sys.argv[2]))
except Exception as ex:
    print("raised", type(ex).__name__, str(ex)[:600]); raise SystemExit
mr = s.mesh_refinement
print("status", s.status, "objective", s.objective, "met", mr["met"], f"cpu {time.process_time() - c0:.1f}")
print("message:", mr["message"])
for i, h in enumerate(mr["history"]):
    print(i, {k: (v if not isinstance(v, (list, np.ndarray)) or len(v) < 6 else f"[{len(v)} values]") for k, v in h.items()})
