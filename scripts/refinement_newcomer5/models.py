"""The four problems of newcomer check 5, written through the public API only (import ocp_constraints as oc)."""
import math
import casadi as ca
import numpy as np
import ocp_constraints as oc

G = 9.81


def rod_inertia(m, L):
    """A slender rod along its body x axis (the psi = 0 direction), turning about z."""
    return np.diag([1e-4, m * L ** 2 / 12, m * L ** 2 / 12])


# ---------------------------------------------------------------- 1. double pendulum, effort + shoulder load
DP = dict(m1=1.2, L1=0.7, m2=0.6, L2=0.5, T=2.5, w_load=0.05)


def dpend():
    p = DP
    model = oc.Model("double_pendulum_load", gravity=(0.0, -G, 0.0))
    a = model.add_body("upper", p["m1"], rod_inertia(p["m1"], p["L1"]), rotation="321")
    b = model.add_body("lower", p["m2"], rod_inertia(p["m2"], p["L2"]), rotation="321")
    oc.joints.revolute(model, "shoulder", a.point("S", (-p["L1"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    oc.joints.revolute(model, "elbow", b.point("E", (-p["L2"] / 2, 0, 0)), axis=(0, 0, 1),
                       other=a.point("E", (p["L1"] / 2, 0, 0)))
    t1, t2 = model.add_input("tau1"), model.add_input("tau2")
    model.add_torque("motor1", a, ca.vertcat(0, 0, t1))
    model.add_torque("motor2", b, ca.vertcat(0, 0, t2), reaction_body=a)
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    pr.initial({"upper.psi": -math.pi / 2, "lower.psi": -math.pi / 2, "upper.omega_z": 0.0, "lower.omega_z": 0.0})
    pr.final({"upper.psi": math.pi / 2, "lower.psi": math.pi / 2, "upper.omega_z": 0.0, "lower.omega_z": 0.0})
    pr.minimize_effort()
    F = pr.joint_force(SHOULDER_CHANNEL)
    pr.minimize_integral(ca.sumsqr(F), weight=p["w_load"], label="shoulder load")
    s = lambda t: -math.pi / 2 + math.pi * np.asarray(t) / p["T"]
    pr.set_guess("upper.psi", s); pr.set_guess("lower.psi", s)
    return pr


SHOULDER_CHANNEL = "shoulder"   # checked against describe()/load channel names


# ---------------------------------------------------------------- 2. pendulum swing-up, hinge force bounded
PF = dict(m=1.0, L=1.0, T=2.0, tau_max=12.0, F_max=15.0)   # unbounded optimum peaks at 25.4 N


def pend_force(F_max=PF["F_max"]):
    p = PF
    model = oc.Model("pendulum_force_bound", gravity=(0.0, -G, 0.0))
    r = model.add_body("rod", p["m"], rod_inertia(p["m"], p["L"]), rotation="321")
    oc.joints.revolute(model, "hinge", r.point("P", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    model.add_torque("motor", r, ca.vertcat(0, 0, model.add_input("tau")))
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    pr.initial({"rod.psi": -math.pi / 2, "rod.omega_z": 0.0})
    pr.final({"rod.psi": math.pi / 2, "rod.omega_z": 0.0})
    pr.bound("tau", -p["tau_max"], p["tau_max"])
    pr.minimize_effort()
    if F_max is not None:
        F = pr.joint_force("hinge")
        pr.subject_to(ca.sumsqr(F), 0.0, F_max ** 2, label="hinge force", scale=F_max ** 2)
    pr.set_guess("rod.psi", lambda t: -math.pi / 2 + math.pi * np.asarray(t) / p["T"])
    return pr


# ---------------------------------------------------------------- 3. RP robot: slider carrying an arm, angle bounded
RP = dict(m_s=2.0, m_a=0.8, L=0.8, T=2.0, D=1.0, w_tau=4.0, psi_max=-1.55)   # unbounded: psi in [-1.778, -1.363]


def rp(psi_max=RP["psi_max"]):
    p = RP
    model = oc.Model("rp_robot", gravity=(0.0, -G, 0.0))
    s = model.add_body("slider", p["m_s"], 0.02 * np.eye(3), rotation="321")
    a = model.add_body("arm", p["m_a"], rod_inertia(p["m_a"], p["L"]), rotation="321")
    oc.joints.prismatic(model, "rail", s.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "pin", a.point("P", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1), other=s.com)
    F, tau = model.add_input("force"), model.add_input("tau")
    model.add_force("drive", s.com, ca.vertcat(F, 0, 0))
    model.add_torque("motor", a, ca.vertcat(0, 0, tau), reaction_body=s)
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    pr.initial({"slider.x": 0.0, "arm.psi": -math.pi / 2, "slider.vbar_x": 0.0, "arm.omega_z": 0.0})
    pr.final({"slider.x": p["D"], "arm.psi": -math.pi / 2, "slider.vbar_x": 0.0, "arm.omega_z": 0.0})
    pr.minimize_effort(["force"])
    pr.minimize_effort(["tau"], weight=p["w_tau"])
    if psi_max is not None:
        pr.bound("arm.psi", upper=psi_max)
    pr.set_guess("slider.x", lambda t: p["D"] * np.asarray(t) / p["T"])
    pr.set_guess("arm.psi", lambda t: -math.pi / 2 + 0 * np.asarray(t))
    return pr


# ---------------------------------------------------------------- 4. rod, free final time, time + effort + terminal miss
FT = dict(m=1.0, L=1.0, tau_max=20.0, w_eff=0.1, W=10.0, target=math.pi / 2, Tb=(0.3, 6.0), T0=1.5)


def free_time():
    p = FT
    model = oc.Model("rod_free_time", gravity=(0.0, -G, 0.0))
    r = model.add_body("rod", p["m"], rod_inertia(p["m"], p["L"]), rotation="321")
    oc.joints.revolute(model, "hinge", r.point("P", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    model.add_torque("motor", r, ca.vertcat(0, 0, model.add_input("tau")))
    pr = oc.OptimalControlProblem(model, t_final=p["T0"], t_final_bounds=p["Tb"])
    pr.initial({"rod.psi": -math.pi / 2, "rod.omega_z": 0.0})
    pr.final({"rod.omega_z": 0.0})
    pr.bound("tau", -p["tau_max"], p["tau_max"])
    pr.minimize_final_time()
    pr.minimize_effort(weight=p["w_eff"])
    pr.minimize_terminal(p["W"] * (pr.quantity("rod.psi") - p["target"]) ** 2, label="miss")
    pr.set_guess("rod.psi", lambda t: -math.pi / 2 + math.pi * np.asarray(t) / p["T0"])
    return pr
