"""The pendulum with its hinge force bounded, at TOL with max_refinements=N (the message's advice), against ref_pend.npz.
    python pend_more_refinements.py [TOL] [N]"""
import os, sys, time
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import models as M
import nc5

tol = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-5
n = int(sys.argv[2]) if len(sys.argv) > 2 else 20
c0 = time.process_time()
sol = M.pend_force().solve(tolerance=tol, max_refinements=n)
cpu = time.process_time() - c0
mr = sol.mesh_refinement
ref = nc5.with_body_states("pend", np.load(os.path.join(nc5.HERE, "ref_pend.npz"), allow_pickle=True)["ref"].item())
e = nc5.errors(sol, "pend", ref)
print(f"tol {tol} max_refinements {n}: met {mr['met']}, {sol.transcription.scheme.point_count} points, CPU {cpu:.1f} s")
print(f"estimate states {mr['estimate']['states']:.2e} multipliers {mr['estimate']['multipliers']:.2e}; "
      f"true states {e['states']:.2e} multipliers {e['multipliers']:.2e} at {e['where']}")
print("estimates along the way (multipliers):", [f"{h['estimate']['multipliers']:.1e}" for h in mr["history"] if isinstance(h.get("estimate"), dict)])
print(mr["message"])
