"""What a newcomer meets closing the four-bar with a revolute joint at B instead of point_on_line
(python api_probe.py [auto|maximal|joint]); one Radau 5 x 10 solve at most."""
import math
import casadi as ca
import numpy as np
import ocp_constraints as oc
import models as M

import sys
COORDS = sys.argv[1] if len(sys.argv) > 1 else "auto"
p = M.FB
model = oc.Model("four_bar_revolute_B", gravity=(0.0, -M.G, 0.0))
bars = {}
for name, length in (("crank", p["a"]), ("coupler", p["b"]), ("rocker", p["c"])):
    m = p["rho"] * length
    bars[name] = model.add_body(name, m, M.rod_inertia(m, length), rotation="321")
crank, coupler, rocker = bars["crank"], bars["coupler"], bars["rocker"]
oc.joints.revolute(model, "O", crank.point("O", (-p["a"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
oc.joints.revolute(model, "A", coupler.point("A", (-p["b"] / 2, 0, 0)), axis=(0, 0, 1), other=crank.point("A", (p["a"] / 2, 0, 0)))
oc.joints.revolute(model, "D", rocker.point("D", (-p["c"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(p["d"], 0, 0))
try:
    oc.joints.revolute(model, "B", rocker.point("B", (p["c"] / 2, 0, 0)), axis=(0, 0, 1), other=coupler.point("B", (p["b"] / 2, 0, 0)))
    model.add_torque("motor", crank, ca.vertcat(0, 0, model.add_input("tau")))
    pr = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=COORDS)
    pr.initial({"crank.psi": 0.0, "crank.psi_dot": 0.0})
    pr.final({"crank.psi": p["theta_f"], "crank.psi_dot": 0.0})
    pr.minimize_effort()
    th = lambda t: p["theta_f"] * (np.asarray(t) / p["T"])
    pr.set_guess("coupler.psi", lambda t: M.fourbar_angles(th(t))[0])
    pr.set_guess("rocker.psi", lambda t: M.fourbar_angles(th(t))[1])
    sol = pr.solve(oc.Radau(10, degree=5))
    print("solved:", sol.status)
except Exception as exc:  # noqa: BLE001
    print(f"{type(exc).__name__}: {str(exc)[:1500]}")
