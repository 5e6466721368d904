"""True errors of a saved refined solve (sol_NAME_TOL.npz from run.py one) outside windows +-w s around the
reference's junctions; states absolute, joint forces relative to the reference's largest load.
    python windows.py NAME TOL [TOL ...]"""
import sys

import numpy as np

import truth

name = sys.argv[1]
for tol in sys.argv[2:]:
    z = np.load(f"sol_{name}_{float(tol):g}.npz")
    t = z["t"]
    st, loads, inp = truth.ref(name, t)
    big = max(float(np.abs(v).max()) for v in loads.values())
    j = truth.junctions(name)
    se = {k: np.abs(z[f"lib:{k}"] - v) for k, v in st.items()}
    le = {k: np.abs(z[f"libF:{k}"] - v) / big for k, v in loads.items()}
    le.update({k: np.abs(z[k]) / big for k in z.files if k.startswith("librest:")})
    ue = {k: np.abs(z[f"libu:{k}"] - v) / np.abs(v).max() for k, v in inp.items()}
    print(f"{name} {tol}: junctions {j}")
    for w in (0.0, 1e-5, 1e-4, 3e-4, 1e-3, 1e-2):
        m = np.ones_like(t, bool)
        for x in j:
            m &= np.abs(t - x) > w
        print(f"  outside +-{w:g} s: states {max(v[m].max() for v in se.values()):.2e}, "
              f"loads {max(v[m].max() for v in le.values()):.2e}, inputs {max(v[m].max() for v in ue.values()):.2e}")
