"""The same unbounded least-effort arm on the default start's first mesh (Radau 5 x 10): from the URDF (quaternions)
and by hand (321 angles, load weight 0): python coords_probe.py"""
import numpy as np
import models as M, ocp_constraints as oc
opts = {"ipopt.print_level": 0, "print_time": False}
for name, pr, u in (("URDF, quaternions", M.urdf_arm(dict(M.ARM)), "shoulder.tau"),
                    ("by hand, 321 angles", M.load_arm(dict(M.ARM, w_load=0.0)), "tau1")):
    for N in (10, 20):
        s = pr.solve(oc.Radau(N, degree=5), opts)
        t = np.linspace(1e-6, 1, 2001)
        print(f"{name:20s} Radau 5 x {N}: {s.status} objective {s.objective:.6f} max|{u}| {np.abs(s.interpolate(u, t)).max():.2f}"
              f" max|link2.omega_z| {np.abs(s.interpolate('link2.omega_z', t)).max():.2f}")
