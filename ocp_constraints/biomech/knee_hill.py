"""Hill-type muscle forces with a rigid tendon (issue 7, step 4).

The tension of muscle m along its path is

    F_m = F0_m [a_m f_L(l) f_V(v) + f_PE(l)] cos(alpha),

affine in the activation ``a_m``: ``F_m = a_m Fa_m + Fp_m`` with ``Fa = F0 f_L f_V cos(alpha)``
(the force at full activation) and ``Fp = F0 f_PE cos(alpha)`` (passive), both fixed by the
kinematics of the frame, so static optimisation stays a convex QP.

Parameters, per muscle, from the model file (``Thelen2003Muscle`` of the JW model, read by
:func:`ocp_constraints.biomech.knee_muscles.muscle_parameters`): ``max_isometric_force`` F0,
``optimal_fiber_length`` l_opt, ``tendon_slack_length`` l_s, ``pennation_angle_at_optimal``
alpha_0. Maximal shortening velocity ``v_max = 10 l_opt / s`` (the usual value; the
Thelen2003Muscle default ``max_contraction_velocity = 10``).

Muscle-tendon units. The fibre kinematics use the length of the muscle-tendon *unit*
the parameters describe (:attr:`~ocp_constraints.biomech.knee_muscles.MusclePaths.unit_length`):
for the quadriceps of the JW model that is the path ending on the patella (the model's
``<name>_withreallength`` twins), not the force path that runs on over the patellar
ligament to the tibia (about 0.1 m longer; it gives the moment arms only). Earlier
versions used the force path here, which made the quadriceps look about 0.1 m too
long and inflated their length factors below to 1.26-1.42.

Scaling of the length parameters. The JW model's right-leg muscles (``Schutte1993Muscle``)
carry generic ``optimal_fiber_length`` and ``tendon_slack_length`` that do not all match
its scaled paths: with a rigid tendon and the model's own values, soleus and gastrocnemii
would work near 1.9 l_opt upright, the peronei near 2.1 (the quadriceps, on their
units, at 0.84 (vasti) and 1.2 (rectus femoris)). As OpenSim's Scale tool does when it
scales a model, both lengths of muscle m are multiplied by one factor
``k_m = L_MT(q_ref) / (l_opt cos(alpha_0) + l_s)``, so that at the reference pose ``q_ref``
(all joint angles zero, upright) the fibre is at its optimal length with the pennation
``alpha_0``; the ratio ``l_opt / l_s`` of the model is kept (:func:`scale_lengths`). This
is an assumption (stated in ``summary.json`` with the factors), not a value of the model
or the literature. With a rigid tendon it puts the vasti at 1.5 l_opt and the rectus
femoris at 1.6 l_opt at the knee flexion of early swing, where the passive curve gives
0.5-1 F0 each: the cause of the large swing-phase contact forces of the Hill model.

Kinematics (rigid tendon, constant-thickness pennation): with the muscle-tendon length
``L_MT(q)`` and its rate ``v_MT = dL_MT/dt = -sum_c r_c qdot_c`` from the fitted paths
(:mod:`ocp_constraints.biomech.knee_muscles`),

    l_M sin(alpha) = l_opt sin(alpha_0),   l_M cos(alpha) = L_MT - l_s,
    v_M = v_MT cos(alpha),

normalised ``l = l_M / l_opt`` and ``v = v_M / v_max`` (v > 0 lengthening).

Curves: De Groote F, Kinney AL, Rao AV, Fregly BJ (2016) "Evaluation of direct collocation
optimal control problem formulations for solving the muscle redundancy problem",
Ann Biomed Eng 44(10):2922-2936, doi:10.1007/s10439-016-1591-9 (Appendix; the same
constants as in their MuscleRedundancySolver and in PredSim):

* active force-length: ``f_L = sum_{i=1..3} b1i exp(-(l - b2i)^2 / (2 (b3i + b4i l)^2))``,
  ``b1 = (0.815, 0.433, 0.1)``, ``b2 = (1.055, 0.717, 1.0)``, ``b3 = (0.162, -0.030, 0.354)``,
  ``b4 = (0.063, 0.200, 0.0)``;
* passive force-length: ``f_PE = (exp(kPE (l - 1) / e0) - 1) / (exp(kPE) - 1)``, ``kPE = 4``,
  ``e0 = 0.6``, taken as zero below ``l = 1`` (it is negative there; a slack fibre pushes nothing);
* force-velocity: ``f_V = d1 log(d2 v + d3 + sqrt((d2 v + d3)^2 + 1)) + d4``,
  ``d1 = -0.318``, ``d2 = -8.149``, ``d3 = -0.374``, ``d4 = 0.886``.

Nothing here is fitted to, or tuned with, the measured knee loads.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

B1 = np.array([0.815, 0.433, 0.1])
B2 = np.array([1.055, 0.717, 1.0])
B3 = np.array([0.162, -0.030, 0.354])
B4 = np.array([0.063, 0.200, 0.0])
KPE, E0 = 4.0, 0.6
D1, D2, D3, D4 = -0.318, -8.149, -0.374, 0.886
VMAX_PER_LOPT = 10.0          # v_max = 10 l_opt / s


def _math(x):
    """CasADi for a CasADi value (the curves in an NLP, :mod:`.knee_tendon_curves`), else NumPy."""
    return ca if isinstance(x, (ca.SX, ca.MX, ca.DM)) else np


def active_force_length(l):
    """De Groote et al. (2016) active force-length curve (normalised fibre length ``l``; numbers, arrays or
    CasADi values): a sum of three Gaussians."""
    m = _math(l)
    l = l if m is ca else np.asarray(l, float)
    out = 0
    for b1, b2, b3, b4 in zip(B1, B2, B3, B4):
        out = out + b1 * m.exp(-0.5 * (l - b2) ** 2 / (b3 + b4 * l) ** 2)
    return out


def passive_force_length(l):
    """De Groote et al. (2016) passive curve, zero for ``l <= 1``."""
    l = np.asarray(l, float)
    return np.where(l > 1.0, (np.exp(KPE * (l - 1.0) / E0) - 1.0) / (np.exp(KPE) - 1.0), 0.0)


def force_velocity(v):
    """De Groote et al. (2016) force-velocity curve (``v = v_M / v_max``, lengthening positive; numbers, arrays
    or CasADi values)."""
    m = _math(v)
    x = D2 * (v if m is ca else np.asarray(v, float)) + D3
    return D1 * m.log(x + m.sqrt(x * x + 1.0)) + D4


def scale_lengths(L_ref, l_opt, l_slack, alpha0):
    """Factors ``k = L_ref / (l_opt cos(alpha0) + l_s)`` and the scaled ``(k l_opt, k l_s)``."""
    l_opt, l_slack, alpha0 = (np.asarray(x, float) for x in (l_opt, l_slack, alpha0))
    k = np.asarray(L_ref, float) / (l_opt * np.cos(alpha0) + l_slack)
    return k, k * l_opt, k * l_slack


@dataclass
class HillForces:
    """Per frame and muscle: force at full activation ``active`` and ``passive`` (N), and the fibre state."""

    active: np.ndarray
    passive: np.ndarray
    fiber_length: np.ndarray      # l_M / l_opt
    fiber_velocity: np.ndarray    # v_M / v_max
    cos_pennation: np.ndarray


def hill_forces(L_mt, V_mt, F0, l_opt, l_slack, alpha0) -> HillForces:
    """Rigid-tendon Hill forces from path lengths ``L_mt`` and rates ``V_mt`` (frames x muscles, m, m/s)."""
    F0, l_opt, l_slack, alpha0 = (np.asarray(x, float) for x in (F0, l_opt, l_slack, alpha0))
    h = l_opt * np.sin(alpha0)
    along = np.maximum(np.asarray(L_mt, float) - l_slack, 1e-6)
    l_m = np.sqrt(along ** 2 + h ** 2)
    cos_a = along / l_m
    l = l_m / l_opt
    v = np.asarray(V_mt, float) * cos_a / (VMAX_PER_LOPT * l_opt)
    active = F0 * active_force_length(l) * force_velocity(v) * cos_a
    passive = F0 * passive_force_length(l) * cos_a
    return HillForces(active, passive, l, v, cos_a)


__all__ = ["HillForces", "scale_lengths", "active_force_length", "force_velocity", "hill_forces", "passive_force_length"]
