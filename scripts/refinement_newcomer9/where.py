"""Where in time the true error of one refined run lies, interval by interval, and where the 50 Hz samples
(the reference's kinks or knots) fall in the final mesh.

    python where.py NAME TOL [--maxref K] [--start N,DEG] [--top 12] [--window T0,T1]

One solve in this process (no cap; run only the cases in the report). Prints the message, the final mesh's
intervals with the largest true states / multipliers error (dense grid, 16 per interval), whether a sample time
lies strictly inside each, and the share of intervals with a sample inside.
"""
import sys
import time
import warnings

import numpy as np

import nc9
import ocp_constraints as oc

warnings.simplefilter("ignore")
argv = sys.argv[1:]
opts = {}
for key in ("--maxref", "--start", "--top", "--window"):
    if key in argv:
        i = argv.index(key); opts[key] = argv[i + 1]; del argv[i:i + 2]
name, tol = argv[0], float(argv[1])
problem = nc9.build(name)
method = None
if "--start" in opts:
    n, d = (int(v) for v in opts["--start"].split(","))
    method = oc.Radau(n, degree=d)
c0 = time.process_time()
sol = problem.solve(method, tolerance=tol, **({"max_refinements": int(opts["--maxref"])} if "--maxref" in opts else {}))
cpu = time.process_time() - c0
mr = sol.mesh_refinement
mesh = np.asarray(mr["mesh"]) * sol.t_final
deg = np.asarray(mr["degrees"])
print(f"{name} tol {tol:g}: met {mr['met']}, {mesh.size - 1} intervals, {sol.t.size} points, CPU {cpu:.1f} s")
print("message:", mr["message"])
print("estimate:", mr["estimate"], "worst:", mr.get("worst"))
ref = nc9.load_ref(name)
scale = float(mr["history"][-1]["load_scale"])
rows = []
for k in range(mesh.size - 1):
    t = np.linspace(mesh[k], mesh[k + 1], 17)
    rc = nc9.ref_columns(ref, t)
    st = max(np.max(np.abs(sol.interpolate(n, t) - rc[n])) for n in nc9.STATE_COLS)
    mu = max(np.max(np.abs(sol.interpolate(n, t) - rc[n])) for n in nc9.MULT_COLS) / scale
    inside = nc9.TK[(nc9.TK > mesh[k] + 1e-9) & (nc9.TK < mesh[k + 1] - 1e-9)]
    rows.append((k, mesh[k], mesh[k + 1], int(deg[k]), st, mu, inside))
top = int(opts.get("--top", 12))
for label, col in (("states", 4), ("multipliers", 5)):
    print(f"\nintervals with the largest true {label} error:")
    for k, a, b, p, st, mu, inside in sorted(rows, key=lambda r: -r[col])[:top]:
        print(f"  [{a:.6f}, {b:.6f}] h={b - a:.2e} deg {p}: states {st:.1e}, multipliers {mu:.1e}; "
              f"samples inside: {', '.join(f'{v:.2f}' for v in inside) or 'none'}")
n_in = sum(1 for r in rows if r[6].size)
print(f"\n{n_in} of {len(rows)} intervals hold a sample time strictly inside; "
      f"{int(sum(r[6].size for r in rows))} of {nc9.TK.size - 2} inner sample times are inside an interval")
print(f"smallest interval {np.min(np.diff(mesh)):.2e} s, largest {np.max(np.diff(mesh)):.2e} s; degrees "
      f"{dict(zip(*np.unique(deg, return_counts=True)))}")
if "--window" in opts:
    lo, hi = (float(v) for v in opts["--window"].split(","))
    print(f"\nintervals overlapping [{lo}, {hi}] s:")
    for k, a, b, p, st, mu, inside in rows:
        if b > lo and a < hi:
            print(f"  [{a:.6f}, {b:.6f}] h={b - a:.2e} deg {p}: states {st:.1e}, multipliers {mu:.1e}; "
                  f"samples inside: {', '.join(f'{v:.2f}' for v in inside) or 'none'}")
