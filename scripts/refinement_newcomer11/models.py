"""The three problems of the eleventh newcomer's check, written with the public API only.

    build(name, bounded=True) -> (problem, info)     name in arm_sat, cart_force, rod_lower

Parameters (bounds chosen from the unbounded optima, see README.md) are in PARAMS.
"""
import math

import casadi as ca
import numpy as np

import ocp_constraints as oc

G = 9.81
E3 = (0, 0, 1)

PARAMS = {
    # two-link arm: links 0.6 m / 1.0 kg and 0.5 m / 0.7 kg, absolute angles from hanging, 1.2 s
    "arm_sat": dict(L1=0.6, m1=1.0, L2=0.5, m2=0.7, T=1.2, th1_f=1.6, th2_f=2.4, tau1_max=None),
    # cart 2 kg, pendulum rod 0.5 kg 0.5 m; cart moved 1 m in 2 s; |pivot F_x| bounded
    "cart_force": dict(mc=2.0, mp=0.5, L=0.5, T=2.0, D=1.0, Fx_max=None),
    # rod 1 kg 1 m, hanging to 2 rad in 1.5 s, tau >= -tau_low
    "rod_lower": dict(m=1.0, L=1.0, T=1.5, th_f=2.0, tau_low=None),
}
BOUNDS = {"arm_sat": 0.0, "cart_force": 0.0, "rod_lower": 0.0}   # filled from bounds.json when present


def _rod_inertia(m, L):
    return m * L**2 / 12 * np.diag([1.0, 0.0, 1.0])


def _load_bounds():
    import json
    from pathlib import Path
    p = Path(__file__).resolve().parent / "bounds.json"
    return json.loads(p.read_text()) if p.exists() else {}


def build(name, bounded=True):
    P = dict(PARAMS[name])
    b = _load_bounds().get(name)
    if name == "arm_sat":
        model = oc.Model("arm_sat", gravity=(0.0, -G, 0.0))
        l1 = model.add_body("l1", P["m1"], _rod_inertia(P["m1"], P["L1"]), rotation="321")
        l2 = model.add_body("l2", P["m2"], _rod_inertia(P["m2"], P["L2"]), rotation="321")
        oc.joints.revolute(model, "shoulder", l1.point("A", [0.0, P["L1"] / 2, 0.0]), axis=E3)
        oc.joints.revolute(model, "elbow", l2.point("A", [0.0, P["L2"] / 2, 0.0]), axis=E3,
                           other=l1.point("B", [0.0, -P["L1"] / 2, 0.0]))
        t1, t2 = model.add_input("tau1"), model.add_input("tau2")
        model.add_torque("shoulder_motor", l1, ca.vertcat(0, 0, t1))
        model.add_torque("elbow_motor", l2, ca.vertcat(0, 0, t2))
        model.add_torque("elbow_reaction", l1, ca.vertcat(0, 0, -t2))
        pb = oc.OptimalControlProblem(model, t_final=P["T"])
        pb.initial({"l1.psi": 0.0, "l2.psi": 0.0, "l1.psi_dot": 0.0, "l2.psi_dot": 0.0})
        pb.final({"l1.psi": P["th1_f"], "l2.psi": P["th2_f"], "l1.psi_dot": 0.0, "l2.psi_dot": 0.0})
        pb.minimize_effort(["tau1", "tau2"])
        # Guess: the unbounded problem's optimum from the default guess (J = 7.9609; guess_arm_sat.npz). Without
        # it the bounded problem goes to another local optimum (J = 6.748, elbow turning 6.6 rad) where tau1 does
        # not reach the bound.
        from pathlib import Path
        gz = np.load(Path(__file__).resolve().parent / "guess_arm_sat.npz")
        for k in ("l1.psi", "l2.psi", "l1.psi_dot", "l2.psi_dot", "tau1", "tau2"):
            pb.set_guess(k, (lambda key: (lambda tt: np.interp(tt, gz["t"], gz[key])))(k.replace(".", "_")))
        if bounded and b:
            pb.bound("tau1", -b, b)
        P["tau1_max"] = b
    elif name == "cart_force":
        model = oc.Model("cart_force", gravity=(0.0, -G, 0.0))
        cart = model.add_body("cart", P["mc"], np.diag([0.01, 0.01, 0.01]), rotation="321")
        pole = model.add_body("pole", P["mp"], _rod_inertia(P["mp"], P["L"]), rotation="321")
        oc.joints.prismatic(model, "rail", cart.com, axis=(1, 0, 0))
        oc.joints.revolute(model, "pivot", pole.point("A", [0.0, P["L"] / 2, 0.0]), axis=E3, other=cart.com)
        u = model.add_input("push")
        model.add_force("push", cart.com, ca.vertcat(u, 0, 0))
        pb = oc.OptimalControlProblem(model, t_final=P["T"])
        pb.initial({"cart.x": 0.0, "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.psi_dot": 0.0})
        pb.final({"cart.x": P["D"], "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.psi_dot": 0.0})
        pb.minimize_effort(["push"])
        if bounded and b:
            fx = pb.joint_force("pivot@pole")[0]      # horizontal force on the pole at the pivot
            pb.subject_to(fx, -b, b, label="pivot_fx")
        P["Fx_max"] = b
    elif name == "rod_lower":
        model = oc.Model("rod_lower", gravity=(0.0, -G, 0.0))
        rod = model.add_body("rod", P["m"], _rod_inertia(P["m"], P["L"]), rotation="321")
        oc.joints.revolute(model, "hinge", rod.point("A", [0.0, P["L"] / 2, 0.0]), axis=E3)
        model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
        pb = oc.OptimalControlProblem(model, t_final=P["T"])
        pb.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
        pb.final({"rod.psi": P["th_f"], "rod.psi_dot": 0.0})
        pb.minimize_effort(["motor"])
        if bounded and b:
            pb.bound("motor", -b, np.inf)
        P["tau_low"] = b
    else:
        raise KeyError(name)
    return pb, P
