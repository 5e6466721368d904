"""Tenth newcomer check: the problems, built only through the public API (``import ocp_constraints as oc``).

    build(name) -> OptimalControlProblem

Names: stiff200, stiff2000 (series-elastic actuator), chain3 (triple pendulum), slew and slew_bound (free rigid
body reoriented by body-fixed torques; the second with |tau_i| <= TAU_MAX), mintime (least-time swing with bounded
motor torque and bounded hinge force magnitude, free final time).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

G = 9.81

# ---- stiff: rod driven through a torsional spring from a rotor
STIFF = dict(m=1.0, L=1.0, m_r=0.2, J_r=0.01, T=1.5, psi1=1.0)
# ---- chain3
CHAIN = dict(m=0.5, L=0.4, T=1.5, final=(0.5, 1.2, 2.0))
# ---- slew
SLEW = dict(J=(1.0, 2.0, 3.0), T=3.0, angle=math.radians(120.0), axis=(1.0, 2.0, 3.0), tau_max=1.6)
# ---- mintime
MINT = dict(m=1.0, L=1.0, psi1=1.5, tau_max=8.0, f_max=14.0, effort_w=0.01, T_guess=1.5, T_bounds=(0.3, 5.0))


def stiff_k(name):
    return float(name[len("stiff"):])


def stiff_final_rotor(k):
    s = STIFF
    return s["psi1"] + s["m"] * G * s["L"] / 2 * math.sin(s["psi1"]) / k


def slew_final_quaternion():
    a = np.asarray(SLEW["axis"], float)
    a = a / np.linalg.norm(a)
    h = SLEW["angle"] / 2
    return np.concatenate([[math.cos(h)], math.sin(h) * a])


def build(name: str, coordinates: str = "auto"):
    import ocp_constraints as oc

    if name.startswith("stiff"):
        k = stiff_k(name)
        s = STIFF
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        rod = model.add_body("rod", s["m"], s["m"] * s["L"] ** 2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
        rotor = model.add_body("rotor", s["m_r"], np.diag([s["J_r"] / 2, s["J_r"] / 2, s["J_r"]]), rotation="321")
        oc.joints.revolute(model, "hinge", rod.point("A", [0.0, s["L"] / 2, 0.0]), axis=(0, 0, 1))
        oc.joints.revolute(model, "bearing", rotor.point("O", [0.0, 0.0, 0.0]), axis=(0, 0, 1))
        # the spring: k (rotor angle - rod angle) on the rod about E3, the opposite on the rotor
        spring = k * (rotor.q[3] - rod.q[3])
        model.add_torque("spring", rod, ca.vertcat(0, 0, spring), reaction_body=rotor)
        model.add_torque("motor", rotor, ca.vertcat(0, 0, model.add_input("motor")))
        pr = oc.OptimalControlProblem(model, t_final=s["T"], coordinates=coordinates)
        pr.initial({"rod.psi": 0.0, "rod.omega_z": 0.0, "rotor.psi": 0.0, "rotor.omega_z": 0.0})
        pr.final({"rod.psi": s["psi1"], "rod.omega_z": 0.0, "rotor.psi": stiff_final_rotor(k), "rotor.omega_z": 0.0})
        pr.minimize_effort(["motor"])
        return pr

    if name == "chain3":
        c = CHAIN
        m, L = c["m"], c["L"]
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        links = [model.add_body(f"l{i}", m, m * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
                 for i in (1, 2, 3)]
        oc.joints.revolute(model, "j1", links[0].point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
        for i in (1, 2):
            oc.joints.revolute(model, f"j{i + 1}", links[i].point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1),
                               other=links[i - 1].point("B", [0.0, -L / 2, 0.0]))
        for i in (0, 1, 2):
            tau = model.add_input(f"tau{i + 1}")
            model.add_torque(f"motor{i + 1}", links[i], ca.vertcat(0, 0, tau),
                             reaction_body=links[i - 1] if i > 0 else None)
        pr = oc.OptimalControlProblem(model, t_final=c["T"], coordinates=coordinates)
        pr.initial({f"l{i}.psi": 0.0 for i in (1, 2, 3)} | {f"l{i}.omega_z": 0.0 for i in (1, 2, 3)})
        pr.final({f"l{i + 1}.psi": v for i, v in enumerate(c["final"])} | {f"l{i}.omega_z": 0.0 for i in (1, 2, 3)})
        pr.minimize_effort()
        return pr

    if name in ("slew", "slew_bound", "slew_ball", "slew_ball_bound"):
        s = SLEW
        model = oc.Model(name, gravity=(0.0, 0.0, 0.0))
        sat = model.add_body("sat", 1.0, np.diag(s["J"]), rotation="quaternion")
        if "ball" in name:   # solve(tolerance=) raises a raw ValueError on a model without constraints (FLAGS):
            # the centre of mass held by a ball joint, whose force is zero (no gravity, no other force)
            oc.joints.ball_and_socket(model, "pivot", sat.com)
        u = [model.add_input(f"tau{i}") for i in (1, 2, 3)]
        # body-fixed torques: tau_i along the body's e_i (add_torque takes the fixed basis)
        model.add_torque("thrusters", sat, u[0] * sat.e(1) + u[1] * sat.e(2) + u[2] * sat.e(3))
        pr = oc.OptimalControlProblem(model, t_final=s["T"], coordinates=coordinates)
        qf = slew_final_quaternion()
        rest = {f"sat.omega_{a}": 0.0 for a in "xyz"} | {f"sat.vbar_{a}": 0.0 for a in "xyz"}
        pr.initial({"sat.x": 0.0, "sat.y": 0.0, "sat.z": 0.0, "sat.qw": 1.0, "sat.qx": 0.0, "sat.qy": 0.0,
                    "sat.qz": 0.0} | rest)
        pr.final({"sat.qw": qf[0], "sat.qx": qf[1], "sat.qy": qf[2], "sat.qz": qf[3]} | rest)
        if name.endswith("_bound"):
            for i in (1, 2, 3):
                pr.bound(f"tau{i}", -s["tau_max"], s["tau_max"])
        pr.minimize_effort()
        return pr

    if name == "mintime":
        c = MINT
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        rod = model.add_body("rod", c["m"], c["m"] * c["L"] ** 2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
        oc.joints.revolute(model, "hinge", rod.point("A", [0.0, c["L"] / 2, 0.0]), axis=(0, 0, 1))
        model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
        pr = oc.OptimalControlProblem(model, t_final=c["T_guess"], t_final_bounds=c["T_bounds"],
                                      coordinates=coordinates)
        pr.initial({"rod.psi": 0.0, "rod.omega_z": 0.0})
        pr.final({"rod.psi": c["psi1"], "rod.omega_z": 0.0})
        pr.bound("motor", -c["tau_max"], c["tau_max"])
        F = pr.joint_force("hinge")
        pr.subject_to(ca.dot(F, F), -np.inf, c["f_max"] ** 2, label="hinge force magnitude", scale=c["f_max"] ** 2)
        pr.minimize_final_time(1.0)
        pr.minimize_effort(["motor"], weight=c["effort_w"])
        return pr
    raise SystemExit(f"unknown problem {name}")


NAMES = ["stiff200", "stiff2000", "chain3", "slew", "slew_bound", "slew_ball", "slew_ball_bound", "mintime"]
