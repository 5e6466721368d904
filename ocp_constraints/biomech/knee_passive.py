"""Passive hip moment of the knee pipeline: the passive structures that ideal muscles leave out.

Ideal force generators (``F = a F0``) have no passive force, and the JW model file has no
ligaments or other passive joint loads at the hip, so without this term every newton metre of
the hip's net moment must come from active muscles. In terminal stance the hip is extended
(down to -29 degrees in ngait_og5), where the stretched anterior capsule and hip flexors pull
the thigh forwards passively. Measured in vivo, the passive hip flexion moment of all passive
structures (Riener & Edrich 1999, J Biomech 32:539-544, eq. for the hip, angles in degrees,
hip flexion and knee flexion positive) is

    M_hip = exp(1.4655 - 0.0034 K - 0.0750 H) - exp(1.3403 - 0.0226 K + 0.0305 H) + 8.072   (N m)

It acts in parallel with the muscles, so the muscles' share of the hip flexion balance
(:mod:`.knee_static`) is ``Q_hip_flexion - M_hip``. Without it the model's hip flexors
(iliacus 622 N, psoas 480 N) saturate in terminal stance and the optimiser recruits the hip
flexors that cross the knee (tensor fasciae latae, sartorius, rectus femoris) and then knee
flexors against their knee extension, which over-loads the knee (issue 15, results/knee/).

Simplifications: the published moment is of one population (ten healthy adults), not of JW;
the part of it that comes from biarticular muscles (the K terms) is applied at the hip only,
not along those muscles' paths over the knee.
"""
from __future__ import annotations

import numpy as np

PASSIVE_HIP = ("riener-edrich-1999", "none")
SOURCE = "Riener & Edrich 1999, J Biomech 32:539-544 (passive hip flexion moment of all passive structures)"


def passive_hip_moment(hip_flexion, knee_flexion_jw) -> np.ndarray:
    """Passive hip flexion moment (N m, + flexion) at the JW model's ``hip_flexion`` (rad, + flexion)
    and ``knee_flexion`` (rad, *negative* in flexion, as in the JW model and its IK files)."""
    H = np.degrees(np.asarray(hip_flexion, float))
    K = -np.degrees(np.asarray(knee_flexion_jw, float))
    return np.exp(1.4655 - 0.0034 * K - 0.0750 * H) - np.exp(1.3403 - 0.0226 * K + 0.0305 * H) + 8.072
