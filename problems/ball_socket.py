"""Two bodies joined by ball-and-socket joints (paper sec. 6).

Body 1 (m1 = 1.0 kg) is held at the origin by a ball-and-socket at its material point
X_O (joint ``socket_O``: ``E_k . v_O = 0``); body 2 (m2 = 0.8 kg) is joined to body 1
at X_C (joint ``socket_C``: ``E_k . v_C1 - E_k . v_C2 = 0``), which yields equal and
opposite forces ``+-sum lambda_k E_k`` on the two bodies at X_C and no moments.

Defaults (SCENES.md), offsets in each body's basis: body 1 center of mass at
r1 = (0.02, -0.50, 0.03) from X_O, X_C at c1 = (0, -1, 0) from X_O,
J1 = [[0.090, 0.002, 0.004], [0.002, 0.010, 0.003], [0.004, 0.003, 0.085]];
body 2 center of mass at r2 = (0.03, -0.40, -0.02) from X_C,
J2 = [[0.045, -0.002, 0.003], [-0.002, 0.008, 0.001], [0.003, 0.001, 0.042]].
Initial 3-1-3 angles (0, pi/2 + 0.4, 0.2) with rates (0.8, 0, 0.5) for body 1,
(0.5, pi/2 - 0.3, -0.3) with rates (-0.5, 1.0, 0) for body 2. Gravity 9.81 along -E3.
``--param quaternion=1`` parameterizes both rotations by unit quaternions instead (the
same motion and loads, without the 3-1-3 singularity).
"""
from __future__ import annotations

import math

import numpy as np

import casadi as ca

from ocp_constraints import EulerSequence, joints, Model, OptimalControlProblem, quaternion_from_rotation, Scene

DESCRIPTION = "two-body chain on ball-and-socket joints (sec. 6): equal and opposite joint forces"

DEFAULTS = {"m1": 1.0, "m2": 0.8, "link_length": 1.0, "gravity": 9.81, "t_final": 10.0, "quaternion": 0.0,
            "task_duration": 2.0, "reach_psi": 0.5, "reach_theta": 0.3}

J1 = [[0.090, 0.002, 0.004], [0.002, 0.010, 0.003], [0.004, 0.003, 0.085]]
J2 = [[0.045, -0.002, 0.003], [-0.002, 0.008, 0.001], [0.003, 0.001, 0.042]]
R1 = np.array([0.02, -0.50, 0.03])
R2 = np.array([0.03, -0.40, -0.02])
ANGLES1, RATES1 = (0.0, math.pi / 2 + 0.4, 0.2), (0.8, 0.0, 0.5)
ANGLES2, RATES2 = (0.5, math.pi / 2 - 0.3, -0.3), (-0.5, 1.0, 0.0)


def _model(p: dict[str, float], actuated: bool) -> Model:
    c1 = np.array([0.0, -p["link_length"], 0.0])
    model = Model("ball_socket", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    rotation = "quaternion" if p["quaternion"] else "313"
    b1 = model.add_body("body1", p["m1"], J1, rotation)
    b2 = model.add_body("body2", p["m2"], J2, rotation)
    O = b1.point("O", -R1)
    C1 = b1.point("C", c1 - R1)
    C2 = b2.point("C", -R2)
    joints.ball_and_socket(model, "socket_O", O)
    joints.ball_and_socket(model, "socket_C", C1, C2)
    if actuated:  # torques (fixed basis) at the two joints; the elbow's reacts on body 1
        shoulder = ca.vertcat(*[model.add_input(f"shoulder_{a}") for a in "xyz"])
        elbow = ca.vertcat(*[model.add_input(f"elbow_{a}") for a in "xyz"])
        model.add_torque("shoulder", b1, shoulder)
        model.add_torque("elbow", b2, elbow, reaction_body=b1)
    return model


def reach(p: dict[str, float]) -> OptimalControlProblem:
    """Move the chain from rest at the scene's initial angles to rest at a reaching pose
    (both links turned by ``reach_psi`` about E3 and raised by ``reach_theta``) in
    ``task_duration``, minimum int |tau|^2 dt over the six joint torques.

    Non-convex with several local optima close in cost (0.80 to 0.89 found): which one
    IPOPT reaches depends on the scheme and mesh, so compare solutions by objective."""
    ocp = OptimalControlProblem(_model(p, actuated=True), t_final=p["task_duration"])
    start = {"body1": ANGLES1, "body2": ANGLES2}
    goal = {"body1": (ANGLES1[0] + p["reach_psi"], ANGLES1[1] - p["reach_theta"], ANGLES1[2]),
            "body2": (ANGLES2[0] + p["reach_psi"], ANGLES2[1] - p["reach_theta"], ANGLES2[2])}
    for values, target in ((start, ocp.initial), (goal, ocp.final)):
        for body, angles in values.items():
            target({f"{body}.{c}": v for c, v in zip(("psi", "theta", "phi"), angles)})
            target({f"{body}.{c}_dot": 0.0 for c in ("psi", "theta", "phi")})
    ocp.minimize_effort()
    return ocp


TASKS = {"reach": reach}


def build(p: dict[str, float]) -> Scene:
    c1 = np.array([0.0, -p["link_length"], 0.0])
    model = _model(p, actuated=False)
    seq = EulerSequence("313")
    Q1, Q2 = (np.asarray(seq.rotation(a)) for a in (ANGLES1, ANGLES2))
    x1 = Q1 @ R1
    x2 = Q1 @ c1 + Q2 @ R2
    coordinates, rates = {}, {}
    for name, x, Q, ang, rt in (("body1", x1, Q1, ANGLES1, RATES1), ("body2", x2, Q2, ANGLES2, RATES2)):
        coordinates.update({f"{name}.{c}": float(v) for c, v in zip("xyz", x)})
        if p["quaternion"]:
            coordinates.update({f"{name}.{c}": v for c, v in zip(("qw", "qx", "qy", "qz"), quaternion_from_rotation(Q))})
            omega = np.asarray(seq.angular_velocity(ang, rt)).ravel()
            rates.update({f"{name}.omega_{c}": w for c, w in zip("xyz", omega)})
        else:
            coordinates.update({f"{name}.{c}": v for c, v in zip(("psi", "theta", "phi"), ang)})
            rates.update({f"{name}.{c}_dot": v for c, v in zip(("psi", "theta", "phi"), rt)})
    return Scene(model, coordinates, rates, t_final=p["t_final"])
