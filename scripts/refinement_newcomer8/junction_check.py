"""Is the pendulum reference's arc entry t1 the optimum? The phase reference (N = 40) with t1 free, then fixed a
little later: the objective falls (J(t1) has an inflection at the free t1, not a minimum), but only because the
free arc then dips below the stop before t1 (the phases carry no bound: checked here on a dense grid). So the
free t1 is the feasible optimum, and the objective pins it only to ~(1e-12)^(1/3): 3e-5 s costs 1e-12.

    python junction_check.py
"""
import numpy as np

import nc8
from reference import Phases

lo = nc8.PEND["lo"]
free = Phases(nc8.spec("pend"), 40).solve()
tt = np.linspace(0, free.t1, 20001)
print(f"free: t1 = {free.t1:.9f}, J = {free.J:.14f}, min psi - lo before t1 = {(free.evaluate(tt)[0][0] - lo).min():+.2e}",
      flush=True)
for d in (-3e-5, 3e-5, 1e-4):
    ph = Phases(nc8.spec("pend"), 40).solve(fix_t1=free.t1 + d)
    tt = np.linspace(0, ph.t1, 20001)
    print(f"t1 = free {d:+.0e}: J - J_free = {ph.J - free.J:+.3e}, min psi - lo before t1 = "
          f"{(ph.evaluate(tt)[0][0] - lo).min():+.2e}", flush=True)
