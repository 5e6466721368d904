"""Where is a bound on a rate ("rod.psi_dot") refused? At ocp.bound, at check_problem, or inside solve?

    python bound_rate_check.py > bound_rate_check.txt
"""
import traceback

import models
import ocp_constraints as oc

P = dict(models.PARAMS["pendulum_tf_speed"])
models.PARAMS["pendulum_tf_speed"]["speed_name"] = "rod.psi_dot"
pb, _ = models.build("pendulum_tf_speed")
print("ocp.bound('rod.psi_dot', -3, 3): accepted (no error at bound time)")
for label, call in (("solve(Radau(10, degree=5))", lambda: pb.solve(oc.Radau(10, degree=5))),
                    ("solve(tolerance=1e-4)", lambda: pb.solve(tolerance=1e-4))):
    try:
        call()
        print(label, ": solved")
    except Exception as e:
        tb = traceback.extract_tb(e.__traceback__)
        print(f"{label}: {type(e).__module__}.{type(e).__name__}: {e}")
        print(f"   raised from {tb[-1].filename.split('ocp_constraints/')[-1]}:{tb[-1].lineno} ({tb[-1].name}), "
              f"traceback depth {len(tb)}")
