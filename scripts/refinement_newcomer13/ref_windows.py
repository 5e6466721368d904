"""The five-bar reference's own accuracy by distance from its junctions: 60x3 against 120x3 intervals (ref_fivebar.pkl
holds both), max difference of states (m, rad, m/s, rad/s) and joint forces (relative to the largest load) outside
windows of +-w s around the fine reference's junctions.   python ref_windows.py"""
import pickle

import numpy as np

import fivebar_ref as fr

d = pickle.load(open("ref_fivebar.pkl", "rb"))
j = fr.Dense(d["fine"]).junctions
near = np.concatenate([x + sg * np.logspace(-8, -2, 400) for x in j for sg in (-1, 1)])
t = np.unique(np.concatenate([np.linspace(0, 1, 8001), near]))   # dense next to the junctions
s1, l1, i1, _, _ = fr.quantities(fr.Dense(d["coarse"]), t)
s2, l2, i2, _, _ = fr.quantities(fr.Dense(d["fine"]), t)
j = fr.Dense(d["fine"]).junctions
big = max(float(np.abs(v).max()) for v in l2.values())
print("junctions (fine)", j, "largest load", big)
for w in (0.0, 1e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2):
    m = np.ones_like(t, bool)
    for x in j:
        m &= np.abs(t - x) > w
    ds = max(float(np.abs(s1[k] - s2[k])[m].max()) for k in s1)
    dl = max(float(np.abs(l1[k] - l2[k])[m].max()) for k in l1) / big
    print(f"outside +-{w:g} s: states {ds:.2e}, loads {dl:.2e}")
