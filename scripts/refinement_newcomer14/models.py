"""The three free-final-time problems of the fourteenth newcomer's check, public API only.

    build(name, eps=None, coordinates=None) -> (problem, P)    name in block_tf, block_tf_speed, pendulum_tf

block_tf      : a block (2 kg) on a prismatic rail along x, gravity -y across the rail, a force input F along the
                rail applied at a point h = 0.5 m above the centre (so the rail carries the moment h F besides the
                normal force m g), rest to rest over D = 1 m, |F| <= 4 N, minimize T + eps int F^2.
block_tf_speed: the same with |vbar_x| <= vmax = 1 m/s (a speed bound, active over a coasting arc).
pendulum_tf_speed: the same with |omega_z| <= w_max = 3 rad/s (a speed bound, active over an arc; a bound on the
                rate "rod.psi_dot" is refused by solve, ModelError, see the report).
block_tf_speed_t0: starting AT the speed bound (v(0) = v_max = 1 m/s, x(0) = 0), to rest at D: the speed arc starts
                at t0 (README: "Not done: ... an arc from t0 or to the end" for state arcs).
block_tf_speed_tend: from rest to x = D AT the speed bound (v(T) = v_max): the speed arc ends at T.
pendulum_tf_speed_path: pendulum_tf_speed with the limit written as subject_to(quantity("rod.psi_dot"), -3, 3)
                (a path constraint of the speeds alone).
pendulum_tf   : a rod (1 kg, 1 m) hinged at its end about z, gravity -y, from hanging at rest (psi = 0) to
                psi = pi/2 at rest, |tau| <= tau_max, minimize T + eps int tau^2.
"""
import casadi as ca
import numpy as np

import ocp_constraints as oc

G = 9.81
PARAMS = {
    "block_tf": dict(m=2.0, D=1.0, F_max=4.0, h=0.5, eps=1e-2, T0=2.0, T_bounds=(0.2, 20.0)),
    "block_tf_speed": dict(m=2.0, D=1.0, F_max=4.0, h=0.5, eps=1e-2, v_max=1.0, T0=2.0, T_bounds=(0.2, 20.0)),
    "pendulum_tf": dict(m=1.0, L=1.0, tau_max=5.0, eps=1e-2, T0=1.5, T_bounds=(0.2, 20.0)),
    "block_tf_speed_tend": dict(m=2.0, D=1.0, F_max=4.0, h=0.5, eps=1e-2, v_max=1.0, T0=2.0, T_bounds=(0.2, 20.0)),
    "block_tf_speed_t0": dict(m=2.0, D=1.0, F_max=4.0, h=0.5, eps=1e-2, v_max=1.0, T0=2.0, T_bounds=(0.2, 20.0)),
    "pendulum_tf_speed_path": dict(m=1.0, L=1.0, tau_max=5.0, eps=1e-2, w_max=3.0, T0=1.5, T_bounds=(0.2, 20.0)),
    "pendulum_tf_speed": dict(m=1.0, L=1.0, tau_max=5.0, eps=1e-2, w_max=3.0, T0=1.5, T_bounds=(0.2, 20.0)),
}


def params(name, eps=None):
    P = dict(PARAMS[name])
    if eps is not None:
        P["eps"] = float(eps)
    return P


def build(name, eps=None, coordinates=None):
    P = params(name, eps)
    kw = {} if coordinates is None else dict(coordinates=coordinates)
    if name in ("block_tf", "block_tf_speed", "block_tf_speed_t0", "block_tf_speed_tend"):
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        b = model.add_body("block", P["m"], P["m"] * 0.1 * np.eye(3), rotation="321")
        oc.joints.prismatic(model, "rail", b.com, axis=(1, 0, 0))
        F = model.add_input("F")
        model.add_force("push", b.point("P", [0.0, P["h"], 0.0]), ca.vertcat(F, 0, 0))
        pb = oc.OptimalControlProblem(model, t_final=P["T0"], t_final_bounds=P["T_bounds"], **kw)
        pb.initial({"block.x": 0.0, "block.vbar_x": P["v_max"] if name == "block_tf_speed_t0" else 0.0})
        pb.final({"block.x": P["D"], "block.vbar_x": P["v_max"] if name == "block_tf_speed_tend" else 0.0})
        pb.bound("F", -P["F_max"], P["F_max"])
        if name in ("block_tf_speed", "block_tf_speed_t0", "block_tf_speed_tend"):
            pb.bound("block.vbar_x", -P["v_max"], P["v_max"])
        pb.minimize_final_time()
        pb.minimize_effort(weight=P["eps"])
    elif name in ("pendulum_tf", "pendulum_tf_speed", "pendulum_tf_speed_path"):
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        L, m = P["L"], P["m"]
        rod = model.add_body("rod", m, m * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
        oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
        model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("tau")))
        pb = oc.OptimalControlProblem(model, t_final=P["T0"], t_final_bounds=P["T_bounds"], **kw)
        pb.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
        pb.final({"rod.psi": np.pi / 2, "rod.psi_dot": 0.0})
        pb.bound("tau", -P["tau_max"], P["tau_max"])
        if name == "pendulum_tf_speed_path":      # as the ModelError for a bound on a rate advises: subject_to
            pb.subject_to(pb.quantity("rod.psi_dot"), -P["w_max"], P["w_max"], "speed limit")
        if name == "pendulum_tf_speed":
            pb.bound(P.get("speed_name", "rod.omega_z"), -P["w_max"], P["w_max"])
        pb.minimize_final_time()
        pb.minimize_effort(weight=P["eps"])
    else:
        raise KeyError(name)
    return pb, P
