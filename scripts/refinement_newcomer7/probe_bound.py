"""Which fixed-mesh solves of the URDF arm converge (the bound on shoulder.tau and the mesh): python probe_bound.py"""
import sys, time, numpy as np
import models as M, ocp_constraints as oc
for tmax, N, d in [(None, 40, 5), (6.0, 40, 5), (4.5, 20, 5), (4.5, 40, 3), (4.5, 10, 5)]:
    pr = M.urdf_arm(dict(M.ARM, tau1_max=tmax))
    c0 = time.process_time()
    try:
        s = pr.solve(oc.Radau(N, degree=d), {"ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": 600})
        u = s.interpolate("shoulder.tau", np.linspace(1e-6, 1, 201))
        print(tmax, N, d, s.status, s.objective, "max|tau1|", np.abs(u).max(), f"{time.process_time()-c0:.1f}s", flush=True)
    except Exception as ex:
        print(tmax, N, d, "FAIL", str(ex)[:150], f"{time.process_time()-c0:.1f}s", flush=True)
