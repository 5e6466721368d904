"""Own accuracy of the shooting references at rtol 1e-12 (used) against rtol 1e-13.

    python ref_tight.py NAME EPS        # NAME pendulum_tf | pendulum_tf_speed  -> ref_tight.txt (appended by hand)
"""
import sys

import numpy as np

import reference

name, eps = sys.argv[1], float(sys.argv[2])
s = np.linspace(0, 1, 8001)
a = reference.evaluate(name, s, eps, 1e-12)
b = reference.evaluate(name, s, eps, 1e-13)
ds = {q: np.abs(a[0][q] - b[0][q]).max() for q in a[0]}
w = max(ds, key=ds.get)
print(f"{name} eps {eps:g}: rtol 1e-12 vs 1e-13: T {abs(a[3]['T'] - b[3]['T']):.2e} s; states {ds[w]:.2e} ({w}); "
      f"loads / load scale {max(np.abs(a[1][q] - b[1][q]).max() for q in a[1]) / a[3]['load_scale']:.2e}; "
      f"tau {np.abs(a[2]['tau'] - b[2]['tau']).max() / np.abs(a[2]['tau']).max():.2e} of its largest; "
      f"junctions {max(abs(x - y) for x, y in zip(a[3]['junctions'], b[3]['junctions'])):.1e} s")
