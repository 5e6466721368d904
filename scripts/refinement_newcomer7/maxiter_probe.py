"""urdf_arm from the default start at TOL with more IPOPT iterations: python maxiter_probe.py TOL MAXITER"""
import sys, time
import models as M, ocp_constraints as oc
pr = M.build("urdf_arm")
c0 = time.process_time()
try:
    s = pr.solve(None, {"ipopt.max_iter": int(sys.argv[2])}, tolerance=float(sys.argv[1]))
    mr = s.mesh_refinement
    print("objective", s.objective, "met", mr["met"], "estimate", mr["estimate"], "points", s.transcription.scheme.point_count,
          f"cpu {time.process_time() - c0:.1f}")
    print("message:", mr["message"][:1200])
except Exception as ex:
    print("raised", type(ex).__name__, str(ex)[:500], f"cpu {time.process_time() - c0:.1f}")
