"""Check a "not met" message that blames an arc's floor: the solution's gap from the bound and its rate on the arc
(between the reference junctions, 1 ms in from each), against the states' estimate and the true error.

    python arcgap.py PROBLEM TOL
"""
import sys

import numpy as np

import nc8

name, tol = sys.argv[1], float(sys.argv[2])
pr = nc8.build(name)
sol = pr.solve(tolerance=tol, progress=False)
r = sol.mesh_refinement
T = nc8.horizon(name)
ph = nc8.reference(name, 80) if name.startswith("pend") else None
jt = nc8.junctions(name, ph)
bname, (lo, hi) = next(iter(pr.bounds.items()))
print("message:", r["message"])
print("estimate:", r["estimate"], "worst:", r.get("worst"))
t = np.linspace(jt[0] + 1e-3, jt[1] - 1e-3, 4001)
v = sol.interpolate(bname, t)
bound = lo if abs(np.median(v) - lo) < abs(np.median(v) - hi) else hi
gap = np.abs(v - bound)
print(f"{bname}: bound {bound}, gap on the arc (dense) max {gap.max():.3e}, at the points:")
s = np.asarray(sol.sample(bname), float)
tp = np.asarray(sol.t, float).ravel() if np.size(sol.t) == np.size(s) else np.linspace(0, T, np.size(s))
on = (tp > jt[0]) & (tp < jt[1])
print(f"   max gap at the collocation points on the arc {np.abs(s[on] - bound).max():.3e} (2x = {2 * np.abs(s[on] - bound).max():.3e})")
speeds = {"block.x": "block.vbar_x", "block.y": "block.vbar_y", "rod.psi": "rod.omega_z"}
if bname in speeds:
    w = np.asarray(sol.sample(speeds[bname]), float)
    print(f"   |{speeds[bname]}| on the arc at the points max {np.abs(w[on]).max():.3e} (exact: 0)")
st, lam, u = nc8.ref_quantities(name, np.linspace(0, T, 20001), ph)
tt = np.linspace(0, T, 20001)
e = {k: np.abs(sol.interpolate(k, tt) - v).max() for k, v in st.items()}
k = max(e, key=e.get)
i = np.argmax(np.abs(sol.interpolate(k, tt) - st[k]))
print(f"true states error {e[k]:.3e} ({k} at t={tt[i]:.4f}); on the arc: "
      f"{max(np.abs(sol.interpolate(q, t) - nc8.ref_quantities(name, t, ph)[0][q]).max() for q in st):.3e}")
