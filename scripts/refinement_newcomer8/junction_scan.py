"""The pendulum reference's objective as a function of the arc's entry time t1 (fixed; t2 free), N = 40 per
phase: how flat it is, and where its minimum lies.

    python junction_scan.py
"""
import numpy as np

import nc8
from reference import Phases

for N in (40,):
    free = Phases(nc8.spec("pend"), N).solve()
    print(f"N={N} free: t1 = {free.t1:.9f}, J = {free.J:.14f}", flush=True)
    for d in (-1e-4, 3e-5, 1e-4, 1e-3):
        ph = Phases(nc8.spec("pend"), N).solve(fix_t1=free.t1 + d)
        t = np.array([free.t1 + 1e-9])
        _, lam, _ = nc8.ref_quantities("pend", t, ph)
        print(f"   t1 = free {d:+.0e}: J - J_free = {ph.J - free.J:+.3e}, t2 = {ph.t2:.7f}, "
              f"hinge v1 at the free t1 {lam['hinge.v1.lambda'][0]:+.3e} N", flush=True)
