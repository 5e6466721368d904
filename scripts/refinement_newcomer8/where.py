"""Where in time the true error of one solve lies (states and multipliers), and the error with the horizon's ends
left out; the message and the located switches.

    python where.py PROBLEM TOL [MAX_REFINEMENTS]
"""
import json
import sys

import numpy as np

import nc8

name, tol = sys.argv[1], float(sys.argv[2])
pr = nc8.build(name)
kw = {"max_refinements": int(sys.argv[3])} if len(sys.argv) > 3 else {}
sol = pr.solve(tolerance=tol, progress=False, **kw)
r = sol.mesh_refinement
T = nc8.horizon(name)
ph = nc8.reference(name, 80) if name.startswith("pend") else None
jt = nc8.junctions(name, ph)
mesh = np.asarray(r["mesh"], float) * T
t = np.concatenate([np.linspace(mesh[k], mesh[k + 1], 17)[:-1] for k in range(len(mesh) - 1)] + [[T]]
                   + [[x - 1e-9, x + 1e-9] for x in jt])
t = np.unique(np.clip(t, 0, T))
st, lam, u = nc8.ref_quantities(name, t, ph)
scale = r.get("load_scale") or 1.0
print("message:", r["message"])
print("met", r["met"], "estimate", json.dumps(r["estimate"], default=str), "load_scale", r.get("load_scale"))
print("switches_located", json.dumps(r.get("switches_located"), default=str))
print("junctions (reference)", jt)
inner = (t > 1e-9) & (t < T - 1e-9)
for k, v in list(st.items()) + list(lam.items()):
    e = np.abs(sol.interpolate(k, t) - v)
    rel = k in lam
    d = scale if rel else 1.0
    i = int(np.argmax(e))
    print(f"{k:18s} max {e.max() / d:.3e} at t={t[i]:.6f}   without the ends {e[inner].max() / d:.3e} at "
          f"t={t[inner][np.argmax(e[inner])]:.6f}" + ("  (relative to load_scale)" if rel else ""))
h = r["history"][-1]
print("last history entry:", json.dumps({k: h[k] for k in h if k not in ("mesh", "degrees")}, default=str)[:1500])
print("keys:", sorted(r.keys()))
# the final mesh around the reference junctions
for x in jt:
    k = int(np.searchsorted(mesh, x)) - 1
    print(f"reference junction {x:.7f} lies in mesh interval [{mesh[k]:.7f}, {mesh[k + 1]:.7f}] "
          f"(h = {mesh[k + 1] - mesh[k]:.2e}, degree {r['degrees'][k]})")
