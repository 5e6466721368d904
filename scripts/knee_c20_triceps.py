"""C20 diagnostic (issue 15): the triceps surae's fibres in ngait_og5's terminal stance (2.65-2.85 s), rigid-tendon Hill
(fibre kinematics of the paths) against C20 (compliant tendon, at its solution), to check the preregistered prediction
that a compliant Achilles tendon raises the gastrocnemii's capacity there.

    python scripts/knee_c20_triceps.py

Prints, per muscle: fibre length range (l_opt), normalized fibre velocity range (v_max), mean capacity
``f_L f_V cos(alpha)`` (the force at full activation / F0) and mean force (N) over the window.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import knee_c20_tendon as k  # noqa: E402
from ocp_constraints.biomech.knee_hill import hill_forces  # noqa: E402
from ocp_constraints.biomech.knee_tendon_curves import active_force_length, force_velocity  # noqa: E402


def main() -> None:
    clock, cpu = time.perf_counter(), time.process_time()
    run = k.inputs(k.J / "reducepoly_subject_GC", "ngait_og5")
    T, F0 = run["tendon"], np.asarray(run["args"][4], float)
    rigid = hill_forces(T["L_mt"], T["V_mt"], F0, T["l_opt"], T["l_slack"], T["alpha0"])
    res = k.c20(run)
    t = np.asarray(run["gait"].t)
    w = (t >= 2.65) & (t <= 2.85)
    print("| muscle | model | fibre length (l_opt) | fibre velocity (v_max) | mean capacity (F0) | mean force (N) |")
    print("|---|---|---|---|---|---|")
    for m in ("gasmed", "gaslat", "soleus"):
        i = run["muscles"].index(m)
        sin0 = np.sin(T["alpha0"][i])
        l, v = res.fibre_length[w, i], res.fibre_velocity[w, i]
        cap = active_force_length(l) * force_velocity(v) * np.sqrt(1 - (sin0 / l) ** 2)
        for name, ll, vv, cc, ff in (("rigid tendon (path kinematics)", rigid.fiber_length[w, i], rigid.fiber_velocity[w, i],
                                      rigid.active[w, i] / F0[i], None),
                                     ("C20", l, v, cap, res.force[w, i])):
            print(f"| {m} | {name} | {ll.min():.2f}-{ll.max():.2f} | {vv.min():+.2f}..{vv.max():+.2f} | {cc.mean():.2f} | "
                  + ("-" if ff is None else f"{ff.mean():.0f}") + " |")
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
