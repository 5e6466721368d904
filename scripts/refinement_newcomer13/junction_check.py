"""Is the reference's first junction (0.337115 s) or the library's located one (0.337283 s) the better one? Solve the
three-phase reference (60 intervals a phase, degree 7) from the fine reference with the first phase's duration held
at each value (the arc's exit free), and with both free; compare objectives.   python junction_check.py"""
import pickle

import numpy as np

import fivebar_ref as fr

d = pickle.load(open("ref_fivebar.pkl", "rb"))
D = fr.Dense(d["fine"])
t = np.linspace(0, 1, 8001)
X, U = D(t)
H = fr.h_line()
dg = d["fine"]["durs"]
for label, fix in (("free", None), ("t1 = 0.337115 (reference)", {0: 0.3371150210631978}),
                   ("t1 = 0.337283 (library, 1e-5/1e-6)", {0: 0.337283})):
    r = fr.solve([60, 60, 60], True, (t, X, U, dg), H, fix=fix)
    print(f"{label}: {r['status']}, J = {r['J']:.13f}, junctions {np.cumsum(r['durs'])[:2]}", flush=True)
