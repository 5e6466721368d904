"""Cylinder sliding on a smooth horizontal plane (paper sec. 3.2, Fig. 3).

Uniform solid cylinder, m = 1.5 kg, radius 0.2 m, length 0.6 m, lying on the plane
(theta = pi/2) with its center of mass at height 0 as in the paper. 3-1-3 angles.
Joint ``plane``: ``E3 . vbar = 0`` and ``(e3 x E3) . omega = 0`` give
``F_c = lambda_1 E3`` at the center of mass and ``M_c = lambda_2 (e3 x E3)`` (eq. 17);
the paper's closed form is ``F_c = m g E3``,
``M_c = I_a psi' phi' (cos(phi) e1 - sin(phi) e2)`` (eq. 18).

Initial state: x = 0.1, y = -0.2, psi = 0.3, phi = 0.5, x' = 0.4, y' = -0.25,
psi' = 1.2, phi' = 5.0.
"""
from __future__ import annotations

import math

from ocp_constraints import joints, Model, Scene

DESCRIPTION = "cylinder on a smooth plane (sec. 3.2): normal force and the moment keeping it flat"

DEFAULTS = {
    "mass": 1.5, "radius": 0.2, "length": 0.6, "gravity": 9.81, "t_final": 10.0,
    "x0": 0.1, "y0": -0.2, "psi0": 0.3, "phi0": 0.5,
    "x_dot0": 0.4, "y_dot0": -0.25, "psi_dot0": 1.2, "phi_dot0": 5.0,
}


def build(p: dict[str, float]) -> Scene:
    m, r, h = p["mass"], p["radius"], p["length"]
    Ia = m * r**2 / 2
    It = m * (3 * r**2 + h**2) / 12
    model = Model("sliding_cylinder", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    cyl = model.add_body("cylinder", m, [[It, 0, 0], [0, It, 0], [0, 0, Ia]], rotation="313")
    joints.sliding_cylinder(model, "plane", cyl)
    coordinates = {"cylinder.x": p["x0"], "cylinder.y": p["y0"], "cylinder.z": 0.0,
                   "cylinder.psi": p["psi0"], "cylinder.theta": math.pi / 2, "cylinder.phi": p["phi0"]}
    rates = {"cylinder.x_dot": p["x_dot0"], "cylinder.y_dot": p["y_dot0"],
             "cylinder.psi_dot": p["psi_dot0"], "cylinder.phi_dot": p["phi_dot0"]}
    return Scene(model, coordinates, rates, t_final=p["t_final"])
