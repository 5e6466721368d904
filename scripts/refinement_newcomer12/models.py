"""The three problems of the twelfth newcomer's check, public API only (`import ocp_constraints as oc`).

    build(name, **opts) -> (problem, P)     name in fuel, mayer, shaft

fuel : a slider on a horizontal rail (prismatic, axis x), gravity -y across the rail, thrust u = up - um applied
       at a point 0.5 m above the centre (so the rail carries a moment h u), moved D in fixed T, rest to rest,
       minimising int (up + um) dt with 0 <= up, um <= u_max (L1 cost, bang-off-bang). opts: reg (quadratic
       regularisation weight on up^2 + um^2, default 0).
mayer: a rod hinged at its end to the ground (revolute about z), no gravity, motor |tau| <= tau_max, maximise the
       final angle in fixed T with zero final speed: minimize_terminal(-psi). Bang-bang, switch at T/2.
shaft: a turntable hinged about z, driven at the prescribed rate Omega(t) by a constraint the user writes
       (moment type: pi = E3 . omega - Omega(t), its multiplier the motor torque), carrying a slider on a radial
       rail (prismatic to the table) with a spring and a force input u along the rail; gravity -z;
       minimise int u^2 dt, r moved from r_a to r_b rest to rest (relative to the table).
"""
import casadi as ca
import numpy as np

import ocp_constraints as oc

G = 9.81
E3 = (0, 0, 1)

PARAMS = {
    "fuel": dict(m=1.0, T=2.0, D=1.0, u_max=4.0, h=0.5),
    "mayer": dict(m=1.0, L=1.0, T=2.0, tau_max=1.0),
    "shaft": dict(M=2.0, It=(0.5, 0.5, 1.0), m=1.0, Is=(0.01, 0.01, 0.02), k=4.0, r0=0.5, ra=0.3, rb=0.8,
                  T=2.0, W0=1.0, W1=0.5, w=2.0),
}


def Omega_np(t, P):
    return P["W0"] + P["W1"] * np.sin(P["w"] * t)


def build(name, reg=0.0, coordinates=None):
    P = dict(PARAMS[name])
    kw = {} if coordinates is None else dict(coordinates=coordinates)
    if name == "fuel":
        model = oc.Model("fuel", gravity=(0.0, -G, 0.0))
        s = model.add_body("slider", P["m"], P["m"] * 0.1 * np.eye(3), rotation="321")
        oc.joints.prismatic(model, "rail", s.com, axis=(1, 0, 0))
        up, um = model.add_input("up"), model.add_input("um")
        model.add_force("thrust", s.point("P", [0.0, P["h"], 0.0]), ca.vertcat(up - um, 0, 0))
        pb = oc.OptimalControlProblem(model, t_final=P["T"], **kw)
        pb.initial({"slider.x": 0.0, "slider.vbar_x": 0.0})
        pb.final({"slider.x": P["D"], "slider.vbar_x": 0.0})
        pb.bound("up", 0.0, P["u_max"])
        pb.bound("um", 0.0, P["u_max"])
        pb.minimize_integral(pb.quantity("up") + pb.quantity("um"), label="fuel")
        if reg:
            pb.minimize_effort(["up", "um"], weight=reg)
        P["reg"] = reg
    elif name == "mayer":
        model = oc.Model("mayer", gravity=(0.0, 0.0, 0.0))
        L, m = P["L"], P["m"]
        rod = model.add_body("rod", m, m * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
        oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=E3)
        model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
        pb = oc.OptimalControlProblem(model, t_final=P["T"], **kw)
        pb.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
        pb.final({"rod.psi_dot": 0.0})
        pb.bound("motor", -P["tau_max"], P["tau_max"])
        pb.minimize_terminal(-pb.quantity("rod.psi"), label="minus_angle")
        # a guess that turns forward (the default guess is at rest)
        th_max = P["tau_max"] / (m * L**2 / 3) * (P["T"] / 2) ** 2
        pb.set_guess("rod.psi", lambda t: th_max * t / P["T"])
    elif name == "shaft":
        model = oc.Model("shaft", gravity=(0.0, 0.0, -G))
        table = model.add_body("table", P["M"], np.diag(P["It"]), rotation="321")
        sl = model.add_body("slider", P["m"], np.diag(P["Is"]), rotation="321")
        oc.joints.revolute(model, "hinge", table.com, axis=E3)
        Om = P["W0"] + P["W1"] * ca.sin(P["w"] * model.t)
        # the user's own moment-type constraint: pi = h . omega + e, h = E3, e = -Omega(t)
        model.add_constraint("motor.drive", ca.dot(ca.DM(E3), table.omega) - Om, joint="motor")
        oc.joints.prismatic(model, "rail", sl.com, other=table.com, axis=(1, 0, 0))
        u = model.add_input("u")
        e1 = table.e(1)
        r = ca.dot(sl.com.position - table.com.position, e1)
        F = (u - P["k"] * (r - P["r0"])) * e1
        model.add_force("push_spring", sl.com, F)
        model.add_force("push_spring_reaction", table.com, -F)
        pb = oc.OptimalControlProblem(model, t_final=P["T"], **kw)
        # independent conditions only: table angle 0, r(0) = ra (slider.x at angle 0), r'(0) = 0 (slider.vbar_x)
        pb.initial({"table.psi": 0.0, "slider.x": P["ra"], "slider.vbar_x": 0.0})
        # the table's final angle is fixed by the drive: phi_T = int Omega; r(T) = rb, r'(T) = 0 through
        # slider.x = rb cos phi_T and slider.vbar_x = r' cos phi_T - r Omega(T) sin phi_T
        phT = P["W0"] * P["T"] + P["W1"] / P["w"] * (1 - np.cos(P["w"] * P["T"]))
        P["phi_T"] = phT
        pb.final({"slider.x": P["rb"] * np.cos(phT),
                  "slider.vbar_x": -P["rb"] * Omega_np(P["T"], P) * np.sin(phT)})
        pb.minimize_effort(["u"])
        P["model"] = model
    else:
        raise KeyError(name)
    return pb, P
