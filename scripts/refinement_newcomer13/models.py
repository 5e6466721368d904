"""Thirteenth newcomer check: three problems built with the public API only (``import ocp_constraints as oc``).

    build(name) -> OptimalControlProblem

Names:
  vehicle   1,200 kg body on a 200 m straight track (prismatic joint along E1, gravity along -E2 so the rail carries
            m g = 11,772 N), min int F^2 over a fixed 20 s, rest to rest, speed bound vbar_x <= 12 m/s (80% of the
            unbounded peak 15 m/s).
  vehicle_free  the same without the speed bound.
  fivebar   planar five-bar linkage, two cranks driven by two torques, end-effector P must stay below the ceiling y_P <= H (h_line.json;
            the unconstrained optimum rises to 0.561 m, its ends at 0.442 and 0.373 m).
  fivebar_free  the same without the path constraint.
  spring    1 kg mass on a rail (prismatic), spring k = m (2 pi)^2 (1 Hz), driven by a force for 25 s (25 periods)
            from rest at 0 to x = 0.1 m, v = 0, min int F^2.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

G = 9.81
VEH = dict(m=1200.0, D=200.0, T=20.0, vmax=12.0)
SPR = dict(m=1.0, omega=2 * math.pi, T=25.0, xT=0.1, vT=0.0)
# five-bar: ground pivots O1 = (0,0), O2 = (d,0); cranks a, couplers b; uniform rods of linear density rho
FB = dict(d=0.3, a=0.25, b=0.35, rho=2.0, T=1.0, th0=(2.0, 1.0), thT=(1.2, 0.2), H_LINE=None)


def _rod(m, L):
    # rod along its body e1
    return m * L**2 / 12 * np.diag([0.0, 1.0, 1.0])


def build(name: str):
    import ocp_constraints as oc

    if name.startswith("vehicle"):
        p = VEH
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        car = model.add_body("car", p["m"], np.diag([400.0, 2000.0, 2000.0]), rotation="321")
        oc.joints.prismatic(model, "rail", car.com, axis=(1, 0, 0), anchor=(0.0, 0.0, 0.0))
        F = model.add_input("drive")
        model.add_force("drive", car.com, ca.vertcat(F, 0, 0))
        pr = oc.OptimalControlProblem(model, t_final=p["T"])
        pr.initial({"car.x": 0.0, "car.vbar_x": 0.0})
        pr.final({"car.x": p["D"], "car.vbar_x": 0.0})
        if name == "vehicle":
            pr.bound("car.vbar_x", -np.inf, p["vmax"])
        pr.minimize_effort(["drive"])
        return pr

    if name == "spring":
        p = SPR
        k = p["m"] * p["omega"] ** 2
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        blk = model.add_body("block", p["m"], np.diag([0.1, 0.1, 0.1]), rotation="321")
        oc.joints.prismatic(model, "rail", blk.com, axis=(1, 0, 0), anchor=(0.0, 0.0, 0.0))
        F = model.add_input("push")
        x = blk.com.position[0]
        model.add_force("spring_push", blk.com, ca.vertcat(F - k * x, 0, 0))
        pr = oc.OptimalControlProblem(model, t_final=p["T"])
        pr.initial({"block.x": 0.0, "block.vbar_x": 0.0})
        pr.final({"block.x": p["xT"], "block.vbar_x": p["vT"]})
        pr.minimize_effort(["push"])
        return pr

    if name.startswith("fivebar"):
        import fivebar_ref as fr
        p = FB
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        a, b, d, rho = p["a"], p["b"], p["d"], p["rho"]
        c1 = model.add_body("crank1", rho * a, _rod(rho * a, a), rotation="321")
        c2 = model.add_body("crank2", rho * a, _rod(rho * a, a), rotation="321")
        k1 = model.add_body("coupler1", rho * b, _rod(rho * b, b), rotation="321")
        k2 = model.add_body("coupler2", rho * b, _rod(rho * b, b), rotation="321")
        E3 = (0, 0, 1)
        oc.joints.revolute(model, "O1", c1.point("O1", (-a / 2, 0, 0)), axis=E3, anchor=(0.0, 0.0, 0.0))
        oc.joints.revolute(model, "O2", c2.point("O2", (-a / 2, 0, 0)), axis=E3, anchor=(d, 0.0, 0.0))
        oc.joints.revolute(model, "A1", k1.point("A1", (-b / 2, 0, 0)), axis=E3, other=c1.point("A1", (a / 2, 0, 0)))
        oc.joints.revolute(model, "A2", k2.point("A2", (-b / 2, 0, 0)), axis=E3, other=c2.point("A2", (a / 2, 0, 0)))
        P1 = k1.point("P", (b / 2, 0, 0))
        oc.joints.point_on_line(model, "P", k2.point("P", (b / 2, 0, 0)), other=P1, axis=E3)
        t1, t2 = model.add_input("tau1"), model.add_input("tau2")
        model.add_torque("motor1", c1, ca.vertcat(0, 0, t1))
        model.add_torque("motor2", c2, ca.vertcat(0, 0, t2))
        pr = oc.OptimalControlProblem(model, t_final=p["T"])
        th0, thT = p["th0"], p["thT"]
        q0, qT = fr.angles(th0), fr.angles(thT)
        pr.initial({"crank1.psi": th0[0], "crank2.psi": th0[1], "crank1.psi_dot": 0.0, "crank2.psi_dot": 0.0})
        pr.final({"crank1.psi": thT[0], "crank2.psi": thT[1], "crank1.psi_dot": 0.0, "crank2.psi_dot": 0.0})
        # guess: cranks linear in time, couplers from the loop closure (the assembly branch with P above)
        s = lambda t: np.asarray(t) / p["T"]
        for i, nm in enumerate(("crank1", "crank2")):
            pr.set_guess(f"{nm}.psi", lambda t, i=i: th0[i] + (thT[i] - th0[i]) * s(t))
        for i, nm in enumerate(("coupler1", "coupler2")):
            pr.set_guess(f"{nm}.psi", lambda t, i=i: np.array([fr.angles((th0[0] + (thT[0] - th0[0]) * si,
                                                                            th0[1] + (thT[1] - th0[1]) * si))[2 + i]
                                                                for si in np.atleast_1d(s(t))]))
        if name == "fivebar":
            H = fr.h_line()
            pr.subject_to(P1.position[1], -np.inf, H, label="end-effector below ceiling")
        pr.minimize_effort(["tau1", "tau2"])
        return pr
    raise SystemExit(f"unknown problem {name}")
