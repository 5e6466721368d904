"""The ball-and-socket rod's final orientation given as -q (the same rotation) instead of q: what a newcomer gets
(python quat_sign_probe.py); two Radau 5 x 20 solves."""
import warnings
import numpy as np
import ocp_constraints as oc
import models as M

qf = M.quat_321(*M.SP["final_321"])
for sign in (1, -1):
    pr = M.sph()
    rest = {"bob.omega_x": 0.0, "bob.omega_y": 0.0, "bob.omega_z": 0.0}
    pr.final({"bob.qw": sign * qf[0], "bob.qx": sign * qf[1], "bob.qy": sign * qf[2], "bob.qz": sign * qf[3], **rest})
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        try:
            sol = pr.solve(oc.Radau(20, degree=5))
            q = np.array([sol.sample(f"bob.q{k}") for k in "wxyz"])
            print(f"final = {sign:+d} q: {sol.status}, objective {sol.objective:.6f}, |q| in [{np.linalg.norm(q, axis=0).min():.6f}, "
                  f"{np.linalg.norm(q, axis=0).max():.6f}], warnings: {[str(x.message)[:200] for x in w]}")
        except Exception as exc:  # noqa: BLE001
            print(f"final = {sign:+d} q: {type(exc).__name__}: {str(exc)[:600]}")
