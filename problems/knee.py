"""Knee (paper sec. 6, Figs. 7-8): the tibia on the held femur, condyle contact forces N_medial, N_lateral.

A thin scene over :mod:`ocp_constraints.biomech.knee_model` (bodies, constraints, the 3-2-1
angles of the tibia relative to the femur and their mapping onto the JW model's knee
coordinates are documented there). The femoral component is held; the tibial tray
hangs below it (gravity along ``+E1``, distal) and is pressed onto both condyles by an
axial follower load ``axial_load`` (N) at the tray origin. Released at rest at
``flexion0_deg`` (psi, positive in flexion) with both condyles on their plateaus, it
swings about the condyle spheres; ``knee_medial.lambda`` and ``knee_lateral.lambda`` are
the normal contact forces, equipollent to one force plus a moment along ``g_2 = g^2``
about the flexion axis (``tests/test_knee.py``).
"""
from __future__ import annotations

import math

from ocp_constraints import Scene
from ocp_constraints.biomech.knee_model import coordinates, default_parameters, knee_model, seated_pose

DESCRIPTION = "knee (sec. 6): tibia on the held femur, condyle contact forces N_medial, N_lateral (moment along g_2)"
DEFAULTS = default_parameters()


def build(p: dict[str, float]) -> Scene:
    angles, origin = seated_pose(p, math.radians(p["flexion0_deg"]))
    return Scene(knee_model(p), coordinates(p, angles, origin), {"tibia.psi_dot": 0.0}, t_final=p["t_final"])
