"""The states' true error at the collocation points against between them, per column, for one refined run
(the tables' "true" is the dense grid: 16 times per final mesh interval through sol.interpolate).

    python check_points.py NAME TOL [--start N,DEG]
"""
import sys
import warnings

import numpy as np

import nc9
import ocp_constraints as oc

warnings.simplefilter("ignore")
argv = sys.argv[1:]
start = None
if "--start" in argv:
    i = argv.index("--start"); start = argv[i + 1]; del argv[i:i + 2]
name, tol = argv[0], float(argv[1])
method = oc.Radau(*(int(v) for v in start.split(",")[:1]), degree=int(start.split(",")[1])) if start else None
sol = nc9.build(name).solve(method, tolerance=tol)
mr = sol.mesh_refinement
ref = nc9.load_ref(name)
mesh = np.asarray(mr["mesh"]) * sol.t_final
td = nc9.dense_grid(mesh, 16)
rp, rd = nc9.ref_columns(ref, sol.t), nc9.ref_columns(ref, td)
print(f"{name} {tol:g}{' from ' + start if start else ''}: met {mr['met']}, {sol.t.size} points; states estimate "
      f"{mr['estimate']['states']:.1e}; NLP coordinates: {mr.get('coordinates')}; worst: {mr.get('worst')}; estimate {mr['estimate']}")
for n in nc9.STATE_COLS:
    ep = np.max(np.abs(np.asarray(sol.sample(n)) - rp[n]))
    ed = np.abs(sol.interpolate(n, td) - rd[n])
    if ed.max() > 0:
        print(f"  {n:14s} at the points {ep:.1e}, between (dense) {ed.max():.1e} at t = {td[np.argmax(ed)]:.4f}")
