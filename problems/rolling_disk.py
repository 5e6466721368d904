"""Thin disk rolling without slipping on a rough horizontal plane (paper sec. 3.3, Fig. 4).

The disk of ``sliding_disk`` (m = 1 kg, R = 0.15 m). Joint ``contact``:
``E_k . v_P = 0`` (k = 1, 2, 3), so ``F_c = sum lambda_k E_k`` at X_P (normal force
``lambda_3`` plus static friction ``lambda_1, lambda_2``), ``M_c = 0``.

Initial state: x = y = psi = phi = 0, theta = 1.2, psi' = 2.0, theta' = 0.3,
phi' = 10.0; the center-of-mass velocity follows from the rolling condition.
"""
from __future__ import annotations

import math

import casadi as ca

from ocp_constraints import joints, Model, OptimalControlProblem, Scene

from ._disk import add_disk, disk_coordinates

DESCRIPTION = "disk rolling on a rough plane (sec. 3.3): normal and friction forces at the contact"

DEFAULTS = {
    "mass": 1.0, "radius": 0.15, "gravity": 9.81, "t_final": 10.0,
    "theta0": 1.2, "psi_dot0": 2.0, "theta_dot0": 0.3, "phi_dot0": 10.0,
    "mu": 0.3, "task_duration": 1.0, "target_x": 0.5, "target_y": 0.2, "target_psi": 0.5,
}


def drive(p: dict[str, float]) -> OptimalControlProblem:
    """Drive the upright disk from rest at the origin (heading psi = 0) to rest at
    (target_x, target_y) with heading target_psi, with torques (fixed basis) on the disk,
    minimum int |tau|^2 dt, the contact force inside the friction cone (mu) with N >= 0."""
    model = Model("rolling_disk", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    disk, P = add_disk(model, p["mass"], p["radius"])
    joints.rolling_contact(model, "contact", P)
    tau = ca.vertcat(*[model.add_input(f"tau_{a}") for a in "xyz"])
    model.add_torque("actuator", disk, tau)
    ocp = OptimalControlProblem(model, t_final=p["task_duration"])
    rest = {"disk.psi_dot": 0.0, "disk.theta_dot": 0.0, "disk.phi_dot": 0.0}
    ocp.initial({"disk.x": 0.0, "disk.y": 0.0, "disk.psi": 0.0, "disk.theta": math.pi / 2, "disk.phi": 0.0, **rest})
    ocp.final({"disk.x": p["target_x"], "disk.y": p["target_y"], "disk.psi": p["target_psi"],
               "disk.theta": math.pi / 2, **rest})
    ocp.minimize_effort()
    ocp.friction_cone("contact", p["mu"])
    return ocp


TASKS = {"drive": drive}


def build(p: dict[str, float]) -> Scene:
    model = Model("rolling_disk", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    disk, P = add_disk(model, p["mass"], p["radius"])
    joints.rolling_contact(model, "contact", P)
    rates = {"disk.psi_dot": p["psi_dot0"], "disk.theta_dot": p["theta_dot0"], "disk.phi_dot": p["phi_dot0"]}
    return Scene(model, disk_coordinates(p["radius"], p["theta0"]), rates, t_final=p["t_final"])
