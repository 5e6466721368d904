"""The thin disk shared by the sliding_disk and rolling_disk scenes (paper Fig. 1)."""
from __future__ import annotations

import math

import casadi as ca

from ocp_constraints import Body, Model, Point


def add_disk(model: Model, mass: float, radius: float) -> tuple[Body, Point]:
    """A thin uniform disk (3-1-3 angles) and its lowest edge point X_P.

    ``x_P - xbar = -R e2''`` with ``e2'' = R3(psi) R1(theta) E2``; in the body basis that
    is ``-R (sin(phi), cos(phi), 0)``, a function of the disk's coordinates.
    """
    disk = model.add_body("disk", mass, [[mass * radius**2 / 4, 0, 0], [0, mass * radius**2 / 4, 0], [0, 0, mass * radius**2 / 2]])
    phi = disk.rotation_parameters[2]
    P = disk.point("P", -radius * ca.vertcat(ca.sin(phi), ca.cos(phi), 0))
    return disk, P


def disk_coordinates(radius: float, theta: float, x: float = 0.0, y: float = 0.0, psi: float = 0.0, phi: float = 0.0) -> dict[str, float]:
    """Coordinates with the edge on the plane: center of mass at height ``R sin(theta)``."""
    return {"disk.x": x, "disk.y": y, "disk.z": radius * math.sin(theta), "disk.psi": psi, "disk.theta": theta, "disk.phi": phi}
