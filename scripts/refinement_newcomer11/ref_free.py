"""Single-phase (no arc) reference for the arm's unsaturated local optimum (J = 6.7484) the default refined solve
reaches: N and 2N intervals of Radau IIA degree 7 warm from ref_arm_sat_J6748.pkl (itself N = 60, from the library's
fixed-mesh solution). Writes ref_arm_sat_free.pkl.

    python ref_free.py [N]        # default N = 120 (and 240)
"""
import json
import pickle
import sys

import numpy as np

import reference as R

N = int(sys.argv[1]) if len(sys.argv) > 1 else 120
g0 = pickle.load(open("ref_arm_sat_J6748.pkl", "rb"))
mk = lambda r: dict(durations=r["durations"], xfun=lambda tt: R._xfun(r, tt), ufun=lambda tt: R._ufun(r, tt))
r1 = R.solve("arm_sat", [("free", 0.0)], N, 7, mk(g0))
r2 = R.solve("arm_sat", [("free", 0.0)], 2 * N, 7, mk(r1))
t = np.linspace(0, 1.2, 12001)
out = {}
for a, b, lab in ((g0, r1, f"60_vs_{N}"), (r1, r2, f"{N}_vs_{2 * N}")):
    s1, l1, u1, _ = R.evaluate(a, t); s2, l2, u2, g2 = R.evaluate(b, t)
    sc = max(np.abs(v).max() for v in l2.values())
    ds = {k: np.abs(s1[k] - s2[k]).max() for k in s1}
    w = max(ds, key=ds.get)
    out[lab] = dict(states=ds[w], worst=w, worst_t=float(t[np.abs(s1[w] - s2[w]).argmax()]),
                    mult=max(np.abs(l1[k] - l2[k]).max() for k in l1) / sc, J=(a["objective"], b["objective"]),
                    max_abs_tau1=float(np.abs(u2["tau1"]).max()))
print(json.dumps(out, indent=1, default=float))
r2["accuracy"] = dict(states_N_vs_2N=out[f"{N}_vs_{2 * N}"]["states"], multipliers_N_vs_2N=out[f"{N}_vs_{2 * N}"]["mult"],
                      load_scale=sc, objective=r2["objective"])
pickle.dump(r2, open("ref_arm_sat_free.pkl", "wb"))
