"""Is the RP robot's reference good enough to judge 1e-6 in the multipliers? The refined solve at TOL (default 1e-6)
against both references (ref_rp.npz: Radau 7 x 400 in phases; refN100_rp.npz: Radau 7 x 200, kept from the first
build, `mv ref_rp.npz refN100_rp.npz` before `NREF=200 python ref.py rp`), channel by channel, near the entry junction
and elsewhere.      python rp_junction_check.py [TOL]"""
import os, sys
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import models as M
from ref import evaluate

tol = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-6
sol = M.rp().solve(tolerance=tol)
mr = sol.mesh_refinement
scale = mr["history"][-1]["load_scale"]
print(mr["message"][:160], "| estimate", {k: f"{v:.2e}" for k, v in mr["estimate"].items()})
t = np.asarray(sol.t); frac = t / sol.t_final
refs = {n: np.load(n, allow_pickle=True)["ref"].item() for n in ("ref_rp.npz", "refN100_rp.npz")}
for n, r in refs.items():
    j = r["junctions"][0] * sol.t_final
    near = np.abs(t[1:] - j) < 0.01
    row = []
    for ch in r["loads"]:
        d = np.abs(np.asarray(sol.sample(ch + ".lambda"))[1:] - evaluate(r, ch, frac[1:], "load")) / scale
        row.append(f"{ch}: near {d[near].max():.2e} away {d[~near].max():.2e}")
    print(f"{n} (entry junction {j:.7f} s):", "; ".join(row))
a, b = refs["ref_rp.npz"], refs["refN100_rp.npz"]
for ch in a["loads"]:
    d = np.abs(evaluate(a, ch, frac[1:], "load") - evaluate(b, ch, frac[1:], "load")) / scale
    print(f"the two references differ at the library's points, {ch}: max {d.max():.2e} at t = {t[1:][np.argmax(d)]:.6f} s")
