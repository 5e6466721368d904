"""Whirling rigid body on a driven shaft (paper sec. 3.4, Fig. 5).

A body of mass 1.2 kg is hinged at its material point X_A (at the origin, on the shaft
axis E3) to a shaft spinning at Omega(t) = omega + omega_amplitude sin(t). 3-1-3 Euler
angles (psi, theta, phi); constraints ``E_k . v_A = 0``, ``g^1 . omega = Omega(t)``,
``g^3 . omega = 0``, all in the joint ``shaft``: ``F_c = sum lambda_k E_k`` at X_A,
``M_c = lambda_4 g^1 + lambda_5 g^3``; ``lambda_4`` is the motor torque and
``lambda_4 Omega`` its power (eq. 27).

Defaults (SI, SCENES.md): center of mass offset from X_A in the body basis
(0.08, -0.45, 0.06); inertia about the center of mass
[[0.040, 0.003, 0.006], [0.003, 0.020, -0.005], [0.006, -0.005, 0.050]];
Omega = 2 rad/s (``omega_amplitude = 0.5`` gives the time-varying variant);
initial psi = 0, theta = pi/2 + 0.5, theta_dot = 0, phi = 0; gravity 9.81 along -E3.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocp_constraints import EulerSequence, joints, Model, OptimalControlProblem, Scene

DESCRIPTION = "body hinged to a shaft driven at Omega(t) (sec. 3.4): motor torque and power"

DEFAULTS = {
    "mass": 1.2,
    "com_x": 0.08, "com_y": -0.45, "com_z": 0.06,
    "J11": 0.040, "J22": 0.020, "J33": 0.050, "J12": 0.003, "J13": 0.006, "J23": -0.005,
    "omega": 2.0,
    "omega_amplitude": 0.0,
    "theta0": math.pi / 2 + 0.5,
    "theta_dot0": 0.0,
    "gravity": 9.81,
    "t_final": 10.0,
    "task_duration": 2.0,
    "task_theta_change": -0.3,
}


def _model(p: dict[str, float], speed_is_input: bool) -> Model:
    model = Model("whirling", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    J = [[p["J11"], p["J12"], p["J13"]], [p["J12"], p["J22"], p["J23"]], [p["J13"], p["J23"], p["J33"]]]
    body = model.add_body("body", p["mass"], J, rotation="313")
    A = body.point("A", -np.array([p["com_x"], p["com_y"], p["com_z"]]))
    joints.ball_and_socket(model, "shaft", A)
    t = model.t
    if speed_is_input:  # Omega(t) chosen by an optimizer: no position form for the drive
        joints.driven_axis(model, "shaft", body, model.add_input("Omega"), index=1)
    else:
        Omega = p["omega"] + p["omega_amplitude"] * ca.sin(t)
        joints.driven_axis(model, "shaft", body, Omega, index=1,
                           rate_integral=p["omega"] * t + p["omega_amplitude"] * (1 - ca.cos(t)), initial_angle=0.0)
    joints.fixed_angle(model, "shaft", body, index=3, value=0.0)
    return model


def hanging_theta(p: dict[str, float]) -> float:
    """The 3-1-3 angle theta at which the body hangs at rest (center of mass lowest)."""
    # With psi = phi = 0 the center of mass is at height com_y sin(theta) + com_z cos(theta),
    # = r cos(theta - beta) with beta = atan2(com_y, com_z): lowest at theta = beta + pi.
    return math.atan2(p["com_y"], p["com_z"]) + math.pi


def spin_up(p: dict[str, float]) -> OptimalControlProblem:
    """Choose the shaft speed Omega(t), from rest and back to rest after ``task_duration``,
    that takes the body from hanging (theta_0) to theta_1 = theta_0 + task_theta_change at
    rest, with the least motor-torque effort int lambda_4^2 dt."""
    model = _model(p, speed_is_input=True)
    theta0 = hanging_theta(p)
    ocp = OptimalControlProblem(model, t_final=p["task_duration"])
    ocp.initial({"body.psi": 0.0, "body.theta": theta0, "body.theta_dot": 0.0, "Omega": 0.0})
    ocp.final({"body.theta": theta0 + p["task_theta_change"], "body.theta_dot": 0.0, "Omega": 0.0})
    ocp.minimize_load_effort(["shaft.drive"])
    return ocp


TASKS = {"spin_up": spin_up}


def build(p: dict[str, float]) -> Scene:
    model = _model(p, speed_is_input=False)
    com = np.array([p["com_x"], p["com_y"], p["com_z"]])
    angles = [0.0, p["theta0"], 0.0]
    Q0 = np.asarray(EulerSequence("313").rotation(angles))
    xbar = Q0 @ com  # X_A at the origin: xbar = -Q r_A
    coordinates = {"body.x": xbar[0], "body.y": xbar[1], "body.z": xbar[2],
                   "body.psi": 0.0, "body.theta": p["theta0"], "body.phi": 0.0}
    return Scene(model, coordinates, {"body.theta_dot": p["theta_dot0"]}, t_final=p["t_final"])
