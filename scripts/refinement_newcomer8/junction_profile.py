"""The library's solution against the reference around the pendulum's arc entry: hinge force v1, motor, psi - lo,
and the collocation points there.

    python junction_profile.py TOL [MAX_REFINEMENTS] [pend|pend_max]
"""
import sys

import numpy as np

import nc8

tol = float(sys.argv[1])
kw = {"max_refinements": int(sys.argv[2])} if len(sys.argv) > 2 and sys.argv[2] != "-" else {}
name = sys.argv[3] if len(sys.argv) > 3 else "pend"
pr = nc8.build(name)
sol = pr.solve(tolerance=tol, progress=False, **kw)
r = sol.mesh_refinement
print(r["message"][:200])
ph = nc8.reference(name, 80)
t1 = ph.t1
mesh = np.asarray(r["mesh"]) * nc8.horizon(name)
print("mesh points near t1:", [f"{m:.7f}" for m in mesh if abs(m - t1) < 3e-4])
tp = np.asarray(sol.t, float).ravel()
print("collocation points near t1:", [f"{x:.7f}" for x in tp if abs(x - t1) < 1.5e-4])
t = t1 + np.array([-3e-4, -1e-4, -5e-5, -2e-5, -1e-5, -1e-9, 1e-9, 1e-5, 2e-5, 5e-5, 1e-4, 3e-4])
st, lam, u = nc8.ref_quantities(name, t, ph)
v1 = sol.interpolate("hinge.v1.lambda", t)
m = sol.interpolate("motor", t)
psi = sol.interpolate("rod.psi", t)
print(f"{'t - t1':>9s} {'v1 lib':>12s} {'v1 ref':>12s} {'motor lib - ref':>16s} {'psi lib - lo':>13s} {'psi ref - lo':>13s}")
for i in range(len(t)):
    print(f"{t[i] - t1:+9.1e} {v1[i]:+12.4e} {lam['hinge.v1.lambda'][i]:+12.4e} {m[i] - u[i]:+16.3e} "
          f"{psi[i] - nc8.PEND['lo']:+13.3e} {st['rod.psi'][i] - nc8.PEND['lo']:+13.3e}")
tt = np.linspace(t1 - 5e-3, t1 + 5e-3, 20001)
print(f"min psi - lo near t1 (library, dense): {(sol.interpolate('rod.psi', tt) - nc8.PEND['lo']).min():+.2e}")
