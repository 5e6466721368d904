"""Is the mintime reference fine enough to judge the not-met 1e-6 / 1e-7 runs? Solve the phased reference again at
2x its intervals (160 in all, from the stored one as the guess), compare with the stored (80), and re-measure the
library's returned solutions at 1e-6 and 1e-7 against both.

    python mintime_ref_check.py
"""
import json
import pickle

import numpy as np

import models
import truth
from reference import Reference

stored = truth.Stored("mintime")
sp = truth.mint_spec(N=40)
for p, dur in zip(sp["phases"], stored.durs):
    p["dur"] = dur
sp["guess_x"] = lambda t: stored.evaluate(np.array([t]))[0][:, 0].tolist()
sp["guess_u"] = lambda t: stored.evaluate(np.array([t]))[2][:, 0].tolist()
fine = Reference(sp).solve()
print("fine:", fine.status, "J", fine.J, "T", fine.T, "junction", fine.junctions, "stored junction", stored.junctions)
s = np.linspace(0, 1, 20001)
a = truth.lib_quantities("mintime", s * stored.T, stored)
b = truth.lib_quantities("mintime", s * fine.T, fine)
print("stored vs fine: states", max(float(np.abs(a[0][k] - b[0][k]).max()) for k in a[0]),
      "loads", max(float(np.abs(a[1][k] - b[1][k]).max()) for k in a[1]) / 14.0)
for tol in (1e-6, 1e-7):
    pr = models.build("mintime")
    sol = pr.solve(tolerance=tol, progress=False)
    r = sol.mesh_refinement
    Tl = float(sol.t_final)
    for lab, ref, st in (("stored", stored, a), ("fine", fine, b)):
        es = max(float(np.abs(sol.interpolate(k, s * Tl) - st[0][k]).max()) for k in st[0])
        el = max(float(np.abs(sol.interpolate(k, s * Tl) - st[1][k]).max()) for k in st[1]) / r["load_scale"]
        print(json.dumps({"tol": tol, "met": r["met"], "ref": lab, "est": r["estimate"], "true_states": es,
                          "true_multipliers": el}))
