"""Where the joint angles of fixed-mesh optima of the URDF arm end (unwrapped from the quaternions along the path):
python winding_fixed_mesh.py TAU1MAX|none N DEGREE"""
import sys, numpy as np
import models as M, ocp_constraints as oc
tm = None if sys.argv[1] == "none" else float(sys.argv[1])
s = M.urdf_arm(dict(M.ARM, tau1_max=tm)).solve(oc.Radau(int(sys.argv[2]), degree=int(sys.argv[3])), {"ipopt.print_level": 0, "print_time": False})
t = np.linspace(0, 1, 4001)
a1 = np.unwrap(2 * np.arctan2(s.interpolate("link1.qz", t), s.interpolate("link1.qw", t)))
a2 = np.unwrap(2 * np.arctan2(s.interpolate("link2.qz", t), s.interpolate("link2.qw", t)))
print(sys.argv[1:], s.status, f"objective {s.objective:.6f}", f"q1 {a1[0]:.3f} -> {a1[-1]:.3f} [{a1.min():.2f}, {a1.max():.2f}]",
      f"q2 {(a2 - a1)[0]:.3f} -> {(a2 - a1)[-1]:.3f} [{(a2 - a1).min():.2f}, {(a2 - a1).max():.2f}]")
