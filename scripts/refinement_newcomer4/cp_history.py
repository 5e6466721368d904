"""The touched cart-pole's refinement, mesh by mesh: points, estimates, shortest interval, IPOPT iterations, CPU.

    python cp_history.py TOL [MAX_REFINEMENTS]
"""
import sys, time, nc4, numpy as np
tol = float(sys.argv[1]); mr_max = int(sys.argv[2]) if len(sys.argv) > 2 else None
ocp = nc4.build("cartpole")
c = time.process_time()
sol = ocp.solve(tolerance=tol, **({} if mr_max is None else {"max_refinements": mr_max}))
mr = sol.mesh_refinement
for h in mr["history"]:
    m = np.array(h["mesh"]); 
    print(h["refinement"], h["points"], h["intervals"], {k: "%.1e" % v for k, v in h.get("estimate", {}).items()}, "min h %.1e" % np.diff(m).min(), "iters", h.get("iterations"), h.get("companion_iterations"), "cpu %.1f" % (h.get("cpu_s",0)+h.get("companion_cpu_s",0)))
print("cpu", time.process_time() - c, mr["met"], mr.get("bounds_passed_between_points"))
print([ (s["quantity"], s["kind"], round(s["t"],4)) for s in mr.get("switches_located", [])][:10])
