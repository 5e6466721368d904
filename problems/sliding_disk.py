"""Thin disk sliding on a smooth horizontal plane (paper secs. 1, 3.3, 4.3, Fig. 1).

Thin uniform disk, m = 1 kg, R = 0.15 m (I = m R^2 / 2 about the normal e3,
m R^2 / 4 about a diameter), its lowest edge point X_P on the plane. Joint ``contact``:
``E3 . v_P = 0``, so ``F_c = lambda E3`` at X_P and ``M_c = 0``; the paper's eq. (4)
gives ``lambda = d/dt(m R theta' cos(theta)) + m g``.

Initial state: x = y = psi = phi = 0, theta = 1.0, x' = 0.3, y' = 0.1, psi' = 3.0,
theta' = 0.4, phi' = -12.0.
"""
from __future__ import annotations

from ocp_constraints import joints, Model, Scene

from ._disk import add_disk, disk_coordinates

DESCRIPTION = "disk sliding on a smooth plane (secs. 1, 3.3): normal force at the contact point"

DEFAULTS = {
    "mass": 1.0, "radius": 0.15, "gravity": 9.81, "t_final": 10.0,
    "theta0": 1.0, "x_dot0": 0.3, "y_dot0": 0.1, "psi_dot0": 3.0, "theta_dot0": 0.4, "phi_dot0": -12.0,
}


def build(p: dict[str, float]) -> Scene:
    model = Model("sliding_disk", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    disk, P = add_disk(model, p["mass"], p["radius"])
    joints.sliding_contact(model, "contact", P)
    rates = {"disk.x_dot": p["x_dot0"], "disk.y_dot": p["y_dot0"], "disk.psi_dot": p["psi_dot0"],
             "disk.theta_dot": p["theta_dot0"], "disk.phi_dot": p["phi_dot0"]}
    return Scene(model, disk_coordinates(p["radius"], p["theta0"]), rates, t_final=p["t_final"])
