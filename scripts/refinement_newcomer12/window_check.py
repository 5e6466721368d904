"""Mayer rod at TOL (default 1e-4): the multipliers at the solution's own points inside the jump window vs
sol.interpolate between them (the window is the whole interval after the switch at the mesh point T/2).

    python window_check.py [TOL] [maximal]
"""
import sys
import warnings

import numpy as np

import models
import reference

tol = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-4
coords = sys.argv[2] if len(sys.argv) > 2 else None
pb, P = models.build("mayer", coordinates=coords)
sol = pb.solve(tolerance=tol)
mr = sol.mesh_refinement
T = P["T"]
print("met", mr["met"], "jump_windows (s)", [[a * T, b * T] for a, b in mr["jump_windows"]], "load_scale", mr["load_scale"])
t = np.asarray(sol.t)
a, b = [x * T for x in mr["jump_windows"][0]]
inside = (t > a) & (t < b)
_, lam, _, _ = reference.evaluate("mayer", t[inside])
ls = mr["load_scale"]
for k in ("hinge.v1.lambda", "hinge.v2.lambda"):
    at_points = np.abs(sol.sample(k)[inside] - lam[k]).max() / ls
    print(f"{k}: at the {inside.sum()} solution points inside the window: error {at_points:.2e} of the load scale")
tt = np.linspace(a, b, 41)[1:-1]
_, lam, _, _ = reference.evaluate("mayer", tt)
with warnings.catch_warnings(record=True) as w:
    warnings.simplefilter("always")
    vals = {k: np.asarray(sol.interpolate(k, tt), float) for k in lam}
print("warnings:", sorted({f"{x.category.__name__}: {str(x.message)[:300]}" for x in w}))
for k in ("hinge.v1.lambda", "hinge.v2.lambda"):
    e = np.abs(vals[k] - lam[k]) / ls
    print(f"{k}: sol.interpolate on 39 times inside the window: error up to {e.max():.2e} of the load scale "
          f"(at t = {tt[e.argmax()]:.3f} s: {vals[k][e.argmax()]:+.5f} N, exact {lam[k][e.argmax()]:+.5f} N)")
# the interval's own collocation polynomial (sol.polynomial), if it gives one
try:
    import inspect
    print("sol.polynomial signature:", inspect.signature(sol.polynomial))
except Exception as e:
    print(repr(e))
