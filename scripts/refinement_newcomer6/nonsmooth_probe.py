"""Why a met estimate is withdrawn as "not smooth": the flagged intervals' inputs and multipliers and their Legendre
decay (python nonsmooth_probe.py PROBLEM TOL [D N]; D N: start from Radau D x N)."""
import sys
import numpy as np
import models as M
import ocp_constraints as oc
from ocp_constraints.ocp.legendre_decay import legendre_decay
from ocp_constraints.ocp.error_estimate import names

pr = M.build(sys.argv[1])
method = oc.Radau(int(sys.argv[4]), degree=int(sys.argv[3])) if len(sys.argv) > 4 else None
sol = pr.solve(method, tolerance=float(sys.argv[2]))
mr = sol.mesh_refinement
print("met", mr["met"], "nonsmooth", mr["nonsmooth_intervals"])
decay, tail = legendre_decay(sol)
tr = sol.transcription
mesh = tr.scheme.mesh_fractions
labels = names(sol)
print("labels", labels["inputs"], labels["multipliers"])
T = float(sol.t_final)
for lo, hi in (mr["nonsmooth_intervals"] or []):
    k = int(np.argmin(np.abs(mesh[:-1] - lo)))
    pts = tr.offsets[k] + np.arange(1, len(tr.interval_points(k)))
    print(f"interval {k} [{mesh[k]:.6f}, {mesh[k + 1]:.6f}] degree {len(pts)}: decay/step {decay[k]:.3f} tail {tail[k]:.2e}")
    t = np.asarray(sol.t)[pts]
    for n in labels["inputs"] + [m for m in labels["multipliers"] if "v1" in m or "v2" in m]:
        v = np.asarray(sol.sample(n))[pts]
        print(f"   {n:18s}", np.array2string(v, precision=10, max_line_width=200))

# the reference's values at the same points, and its Legendre decay on the same interval
from ref import evaluate
import nc6
ref = nc6.load_ref(sys.argv[1])
from numpy.polynomial import legendre
for lo, hi in (mr["nonsmooth_intervals"] or []):
    k = int(np.argmin(np.abs(mesh[:-1] - lo)))
    pts = tr.offsets[k] + np.arange(1, len(tr.interval_points(k)))
    fr = np.asarray(tr.fractions)[pts]
    x = 2 * (fr - mesh[k]) / (mesh[k + 1] - mesh[k]) - 1
    for n in ("hinge.v1", "hinge.v2"):
        rv = evaluate(ref, n, fr, "load"); lv = np.asarray(sol.sample(n + ".lambda"))[pts]
        print(f"interval {k} {n}: ref {np.array2string(rv, precision=10)} lib - ref {np.array2string(lv - rv, precision=3)}"
              f"  Legendre coefficients ref {np.array2string(legendre.legfit(x, rv, len(x) - 1), precision=4)}")
