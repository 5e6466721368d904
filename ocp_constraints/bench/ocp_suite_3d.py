"""The user-problem suite, our side, continued: a rolling disk under a friction cone, a quadrotor
carrying a pendulum load, and a planar five-link walker's step (see :mod:`.ocp_suite`)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

import ocp_constraints as oc

from . import ocp_suite_params as P
from .ocp_suite import rod_inertia


def rolling_disk(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """A thin disk (3-1-3 angles, symmetry axis e3) rolling without slipping on the plane z = 0,
    driven by a torque (fixed basis, three inputs) from rest upright at the origin to rest upright
    at (x, y) with heading psi; min int |tau|^2, the contact force inside the friction cone.
    The contact point is the disk's lowest edge point, ``-R (sin phi, cos phi, 0)`` in the body basis."""
    p = P.DISK
    m, R = p["m"], p["R"]
    model = oc.Model("rolling_disk", gravity=(0.0, 0.0, -P.G))
    disk = model.add_body("disk", m, np.diag([m * R**2 / 4, m * R**2 / 4, m * R**2 / 2]), rotation="313")
    phi = disk.rotation_parameters[2]
    contact = disk.point("contact", -R * ca.vertcat(ca.sin(phi), ca.cos(phi), 0))
    oc.joints.rolling_contact(model, "contact", contact)
    tau = ca.vertcat(*[model.add_input(f"tau_{a}") for a in "xyz"])
    model.add_torque("hands", disk, tau)
    ocp = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    rest = {"disk.psi_dot": 0.0, "disk.theta_dot": 0.0, "disk.phi_dot": 0.0}
    ocp.initial({"disk.x": 0.0, "disk.y": 0.0, "disk.psi": 0.0, "disk.theta": math.pi / 2, "disk.phi": 0.0, **rest})
    ocp.final({"disk.x": p["x"], "disk.y": p["y"], "disk.psi": p["psi"], "disk.theta": math.pi / 2, **rest})
    ocp.friction_cone("contact", p["mu"])
    ocp.minimize_effort()
    return ocp


def quadrotor_load(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """A quadrotor (unit quaternion) with four rotor thrusts along its e3 and their drag torque
    about e3, carrying a small ball on a massless rod of length L hung from a hook below its center:
    the rod is one constraint written by hand between two bodies, ``f . v_ball - f . v_hook = 0``
    with ``f = (x_ball - x_hook) / L`` (position form ``(|x_ball - x_hook|^2 - L^2) / 2L``). From
    hovering at the origin to hovering at (x, y, z), rest to rest with the ball hanging, min int
    sum f_k^2, 0 <= f_k <= f_max."""
    p = P.QUAD
    model = oc.Model("quadrotor_load", gravity=(0.0, 0.0, -P.G))
    quad = model.add_body("quad", p["M"], np.diag([p["Ixx"], p["Iyy"], p["Izz"]]), rotation="quaternion")
    Ib = 2 / 5 * p["m_load"] * p["r_load"] ** 2
    ball = model.add_body("ball", p["m_load"], Ib * np.eye(3), rotation="321")
    hook = quad.point("hook", (0, 0, -p["hook"]))
    r = ball.com.position - hook.position
    f = r / p["L"]
    model.add_constraint("rod", ca.dot(f, ball.com.v) - ca.dot(f, hook.v), position=(ca.dot(r, r) - p["L"] ** 2) / (2 * p["L"]))
    a = p["arm"]
    thrust = [model.add_input(f"f{k + 1}") for k in range(4)]
    for k, (x, y) in enumerate(((a, 0), (0, a), (-a, 0), (0, -a))):
        model.add_force(f"rotor{k + 1}", quad.point(f"rotor{k + 1}", (x, y, 0)), thrust[k] * quad.e(3))
    model.add_torque("drag", quad, p["k"] * (thrust[0] - thrust[1] + thrust[2] - thrust[3]) * quad.e(3))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    still = {f"{b}.{s}": 0.0 for b in ("quad", "ball") for s in ("vbar_x", "vbar_y", "vbar_z")}
    still.update({f"quad.omega_{c}": 0.0 for c in "xyz"})
    level = {"quad.qw": 1.0, "quad.qx": 0.0, "quad.qy": 0.0, "quad.qz": 0.0}
    below = -p["hook"] - p["L"]
    ocp.initial({"quad.x": 0.0, "quad.y": 0.0, "quad.z": 0.0, **level, **still, "ball.x": 0.0, "ball.y": 0.0,
                 "ball.z": below, "ball.psi": 0.0, "ball.theta": 0.0, "ball.phi": 0.0,
                 **{f"ball.omega_{c}": 0.0 for c in "xyz"}})
    # Level at the end: qx = qy = qz = 0 (the NLP's row |q|^2 = 1 fixes qw; a fourth value would be one
    # more, consistent, row). Before that row the norm drifted by 1.8e-4 at N = 20 and IPOPT took 18
    # iterations where it now takes 7 (the same objective to 2e-8).
    ocp.final({"quad.x": p["x"], "quad.y": p["y"], "quad.z": p["z"], **{k: v for k, v in level.items() if k != "quad.qw"},
               **still, "ball.x": p["x"], "ball.y": p["y"]})
    for name in thrust:
        ocp.bound(name.name(), 0.0, p["f_max"])
    ocp.minimize_effort()
    return ocp


LINKS = ("stance_shank", "stance_thigh", "torso", "swing_thigh", "swing_shank")


def walker(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """Five rods in the E1-E2 plane, each along its body e2 from its lower end to its upper end
    (3-2-1 angles; a lean of the upper end towards +E1 is psi = -lean): the stance foot on a
    revolute joint to the ground at the origin, knees and hips revolute joints between bodies, motor
    torques at the ankle (stance shank against the foot on the ground), hips (thigh against torso)
    and knees (shank against thigh). The swing leg swings from behind to ahead, rest to rest; the stance contact's normal force >= 0, its friction cone, its center of pressure on the
    foot (|ankle torque| <= half foot length * normal force), the swing foot above the ground,
    knees flexing forwards only; min int sum tau^2."""
    p = P.WALKER
    model = oc.Model("walker", gravity=(0.0, -P.G, 0.0))
    body = {}
    for name in LINKS:
        part = name.split("_")[-1]
        m, length = p[f"m_{part}"], p[f"l_{part}"]
        b = model.add_body(name, m, rod_inertia(m, length, 1), rotation="321")
        body[name] = (b, b.point("low", (0, -length / 2, 0)), b.point("high", (0, length / 2, 0)))
    ss, ss_low, ss_high = body["stance_shank"]
    st, st_low, st_high = body["stance_thigh"]
    tr, tr_low, _ = body["torso"]
    wt, wt_low, wt_high = body["swing_thigh"]
    ws, ws_low, ws_high = body["swing_shank"]
    oc.joints.revolute(model, "ankle", ss_low)
    oc.joints.revolute(model, "knee1", st_low, other=ss_high)
    oc.joints.revolute(model, "hip1", tr_low, other=st_high)
    oc.joints.revolute(model, "hip2", wt_high, other=tr_low)
    oc.joints.revolute(model, "knee2", ws_high, other=wt_low)
    ankle = model.add_input("ankle")
    model.add_torque("ankle", ss, ca.vertcat(0, 0, ankle))
    for name, child, parent in (("hip1", st, tr), ("hip2", wt, tr), ("knee1", ss, st), ("knee2", ws, wt)):
        model.add_torque(name, child, ca.vertcat(0, 0, model.add_input(name)), reaction_body=parent)
    ocp = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    stance = [p["stance_shank"], p["stance_thigh"], p["torso"]]
    a, b = p["swing_thigh"], p["swing_shank"]
    for ends, swing in ((ocp.initial, [a, b]), (ocp.final, [-b, -a])):
        ends({**{f"{n}.psi": -lean for n, lean in zip(LINKS, stance + swing)}, **{f"{n}.psi_dot": 0.0 for n in LINKS}})
    ocp.friction_cone("ankle", p["mu"], normal=(0, 1, 0))
    normal = ocp.joint_force("ankle")[1]
    ocp.subject_to(ocp.quantity("ankle") - p["foot"] * normal, -np.inf, 0.0, "center of pressure, toe")
    ocp.subject_to(ocp.quantity("ankle") + p["foot"] * normal, 0.0, np.inf, "center of pressure, heel")
    ocp.subject_to(ws_low.position[1], 0.0, np.inf, "swing foot above the ground")
    for shank, thigh in (("stance_shank", "stance_thigh"), ("swing_shank", "swing_thigh")):
        flexion = ocp.quantity(f"{thigh}.psi") - ocp.quantity(f"{shank}.psi")     # lean of shank - lean of thigh
        ocp.subject_to(flexion, 0.0, np.inf, f"{shank} knee flexes forwards")
    ocp.minimize_effort()
    return ocp
