"""Passive joint moments of the knee pipeline: the passive structures that ideal muscles leave out.

Two models: the hip equation alone (``riener-edrich-1999``, candidate C5) and the paper's hip,
knee and ankle equations together (``riener-edrich-1999-hip-knee-ankle``, candidate C7,
:func:`passive_generalized_forces`). The hip equation, why it matters:

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

from .knee_options import PASSIVE_HIP

HIP_KNEE_ANKLE = PASSIVE_HIP[1]
SOURCE = "Riener & Edrich 1999, J Biomech 32:539-544 (passive hip flexion moment of all passive structures)"
SOURCE_ALL = ("Riener & Edrich 1999, J Biomech 32:539-544 (passive hip flexion, knee flexion and ankle "
              "plantarflexion moments of all passive structures)")


def passive_hip_moment(hip_flexion, knee_flexion_jw) -> np.ndarray:
    """Passive hip flexion moment (N m, + flexion) at the JW model's ``hip_flexion`` (rad, + flexion)
    and ``knee_flexion`` (rad, *negative* in flexion, as in the JW model and its IK files)."""
    H = np.degrees(np.asarray(hip_flexion, float))
    K = -np.degrees(np.asarray(knee_flexion_jw, float))
    return np.exp(1.4655 - 0.0034 * K - 0.0750 * H) - np.exp(1.3403 - 0.0226 * K + 0.0305 * H) + 8.072


def passive_knee_moment(hip_flexion, knee_flexion_jw, ankle_angle_jw) -> np.ndarray:
    """Passive knee *flexion* moment (N m) of Riener & Edrich 1999 (knee equation; angles in degrees,
    hip flexion ``H``, knee flexion ``K`` and ankle plantarflexion ``A`` positive):
    ``exp(1.800 - 0.0460 A - 0.0352 K + 0.0217 H) - exp(-3.971 - 0.0004 A + 0.0495 K - 0.0128 H)
    - 4.820 + exp(2.220 - 0.150 K)``. Inputs are the JW coordinates (rad): ``knee_flexion`` negative
    in flexion, ``ankle_angle`` positive in dorsiflexion."""
    H = np.degrees(np.asarray(hip_flexion, float))
    K = -np.degrees(np.asarray(knee_flexion_jw, float))
    A = -np.degrees(np.asarray(ankle_angle_jw, float))
    return (np.exp(1.800 - 0.0460 * A - 0.0352 * K + 0.0217 * H) - np.exp(-3.971 - 0.0004 * A + 0.0495 * K - 0.0128 * H)
            - 4.820 + np.exp(2.220 - 0.150 * K))


def passive_ankle_moment(knee_flexion_jw, ankle_angle_jw) -> np.ndarray:
    """Passive ankle *plantarflexion* moment (N m) of Riener & Edrich 1999 (ankle equation, as
    :func:`passive_knee_moment`): ``exp(2.1016 - 0.0843 A - 0.0176 K) - exp(-7.9763 + 0.1949 A +
    0.0008 K) - 1.792``."""
    K = -np.degrees(np.asarray(knee_flexion_jw, float))
    A = -np.degrees(np.asarray(ankle_angle_jw, float))
    return np.exp(2.1016 - 0.0843 * A - 0.0176 * K) - np.exp(-7.9763 + 0.1949 * A + 0.0008 * K) - 1.792


def passive_generalized_forces(model: str, coordinate_names: list[str], P: np.ndarray) -> dict[str, np.ndarray]:
    """Generalized forces of the passive structures on the JW coordinates (N m per frame), by ``model``
    (:data:`PASSIVE_HIP`): ``+M_hip`` on ``hip_flexion``, and with the hip-knee-ankle model ``-M_knee``
    on ``knee_flexion`` (flexion is negative there) and ``-M_ankle`` on ``ankle_angle`` (plantarflexion
    is negative there). The muscles' share of a balance is ``Q`` minus these."""
    if model == "none":
        return {}
    col = {c: P[:, coordinate_names.index(c)] for c in ("hip_flexion", "knee_flexion", "ankle_angle")}
    out = {"hip_flexion": passive_hip_moment(col["hip_flexion"], col["knee_flexion"])}
    if model == HIP_KNEE_ANKLE:
        out["knee_flexion"] = -passive_knee_moment(col["hip_flexion"], col["knee_flexion"], col["ankle_angle"])
        out["ankle_angle"] = -passive_ankle_moment(col["knee_flexion"], col["ankle_angle"])
    return out


def less_fibre_passive(moments: dict[str, np.ndarray], R: np.ndarray, fibre_force: np.ndarray
                       ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Split Riener & Edrich's passive moments into the muscle fibres' share and the rest (N m per frame).

    Riener & Edrich 1999 measured the passive moment of *all* passive structures, the muscles'
    passive tension included. With Hill muscles the fibres' passive force ``Fp`` (frames x
    muscles, N) already acts along their paths, giving ``sum_m r_mc Fp_m`` on coordinate ``c``
    (``R``: frames x rows x muscles, rows in :data:`.knee_static.RESERVED` order first). So the
    joint-level moment that is left for the other structures (capsule, ligaments) is
    ``M_c - sum_m r_mc Fp_m``, and the total passive moment on ``c`` stays the measured ``M_c``:
    counted once. Returns ``(joint_level, fibres)`` keyed as ``moments``. Where the fibres give
    more than ``M_c`` the joint-level part changes sign: the fibre model (rigid tendon, scaled
    lengths, :mod:`.knee_hill`) is then stiffer than the measured joint, and the remainder says
    by how much.
    """
    from .knee_static import RESERVED

    fibres = {c: np.einsum("nm,nm->n", R[:, RESERVED.index(c), :], fibre_force) for c in moments}
    return {c: m - fibres[c] for c, m in moments.items()}, fibres


def less_joint_passive(Qc: np.ndarray, moments: dict[str, np.ndarray]) -> np.ndarray:
    """The muscles' (and reserves') share of the balances, ``Q - M_passive`` (N m; rows in
    :data:`.knee_static.RESERVED` order first): the passive structures act in parallel with the muscles."""
    from .knee_static import RESERVED

    Qc = Qc.copy()
    for c, m in moments.items():
        Qc[:, RESERVED.index(c)] -= m
    return Qc
