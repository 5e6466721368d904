"""Body on a revolute joint about a fixed point (paper sec. 3.1, Fig. 2).

A uniform thin rod (m = 1 kg, L = 1 m) hinged at one end at the origin, hinge axis E3,
gravity 9.81 along -E2, so it swings in the E1-E2 plane. The rod's axis is tilted
``tilt`` (default 30 deg) out of the swing plane towards +E3: its direction in the body
basis is (0, -cos tilt, sin tilt), and the hinge carries constraint moments about E1
and E2 (eq. 15). ``tilt = 0`` is the planar rod. Released at rest at ``angle0``
(default 60 deg) about E3 from hanging straight down. 3-2-1 Euler angles (the motion is
a rotation about E3, where 3-1-3 angles are singular). Joint ``hinge``:
``E_k . v_A = 0``, ``E1 . omega = 0``, ``E2 . omega = 0``.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocp_constraints import joints, Model, OptimalControlProblem, Scene

DESCRIPTION = "tilted rod on a revolute joint (sec. 3.1): hinge force and two constraint moments"

DEFAULTS = {"mass": 1.0, "length": 1.0, "tilt_deg": 30.0, "angle0_deg": 60.0, "gravity": 9.81, "t_final": 10.0,
            "max_torque": 20.0}


def _model(p: dict[str, float], tilt_deg: float, actuated: bool) -> tuple[Model, np.ndarray]:
    m, L = p["mass"], p["length"]
    tilt = math.radians(tilt_deg)
    d = np.array([0.0, -math.cos(tilt), math.sin(tilt)])
    # Thin rod: m L^2 / 12 about every axis normal to d, nothing about d.
    inertia = m * L**2 / 12 * (np.eye(3) - np.outer(d, d))
    model = Model("pendulum", gravity=(0.0, -p["gravity"], 0.0), parameters=p)
    rod = model.add_body("rod", m, inertia, rotation="321")
    A = rod.point("A", -L / 2 * d)
    joints.revolute(model, "hinge", A, axis=(0, 0, 1))
    if actuated:
        model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    return model, d


def swing_up(p: dict[str, float]) -> OptimalControlProblem:
    """Swing-up (issue 3): the rod in the swing plane, a motor torque about E3 at the hinge
    with |torque| <= max_torque, from hanging at rest to upright at rest in T = 2 s,
    minimum integral of torque squared."""
    model, _ = _model(p, 0.0, actuated=True)
    ocp = OptimalControlProblem(model, t_final=2.0)
    ocp.bound("motor", -p["max_torque"], p["max_torque"])
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    # A guess that first swings back: the straight line from 0 to pi leads IPOPT to a
    # worse local optimum (a one-way swing, objective 13.67 instead of 8.91).
    ocp.set_guess("rod.psi", lambda t: math.pi * t / 2 - np.sin(math.pi * t / 2))
    return ocp


TASKS = {"swing_up": swing_up}


def build(p: dict[str, float]) -> Scene:
    model, d = _model(p, p["tilt_deg"], actuated=False)
    L = p["length"]
    a = math.radians(p["angle0_deg"])
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    xbar = R @ (L / 2 * d)
    coordinates = {"rod.x": xbar[0], "rod.y": xbar[1], "rod.z": xbar[2], "rod.psi": a, "rod.theta": 0.0, "rod.phi": 0.0}
    return Scene(model, coordinates, {"rod.psi_dot": 0.0}, t_final=p["t_final"])
