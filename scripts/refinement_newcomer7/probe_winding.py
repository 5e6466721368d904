"""The URDF arm's optimum found by solve(tolerance=1e-3) and by fixed meshes: objective, and the joint angles' path
(unwrapped from the quaternions: where q1, q2 end, a full turn away from the boundary values or not).
python probe_winding.py [TAU1MAX|none] [TOL]"""
import sys, time, numpy as np
import models as M, ocp_constraints as oc
tm = None if sys.argv[1] == "none" else float(sys.argv[1])
pr = M.urdf_arm(dict(M.ARM, tau1_max=tm))
c0 = time.process_time()
s = pr.solve(tolerance=float(sys.argv[2]))
t = np.linspace(0, 1, 2001)
a1 = np.unwrap(2 * np.arctan2(s.interpolate("link1.qz", t), s.interpolate("link1.qw", t)))
a2 = np.unwrap(2 * np.arctan2(s.interpolate("link2.qz", t), s.interpolate("link2.qw", t)))
print(tm, s.status, "objective", s.objective, "met", s.mesh_refinement["met"], f"cpu {time.process_time()-c0:.1f}")
print("q1 from", a1[0], "to", a1[-1], "range", a1.min(), a1.max(), "| q2 from", (a2 - a1)[0], "to", (a2 - a1)[-1], "range", (a2 - a1).min(), (a2 - a1).max())
print("max|tau1|", np.abs(s.interpolate("shoulder.tau", t[1:])).max())
