"""Hill muscle with a compliant tendon: the curves and the fibre-tendon equilibrium (issue 15, candidate C20).

De Groote F, Kinney AL, Rao AV, Fregly BJ (2016) "Evaluation of direct collocation optimal control problem
formulations for solving the muscle redundancy problem", Ann Biomed Eng 44:2922-2936,
doi:10.1007/s10439-016-1591-9 (supplement, eqs. S1-S4), in the parameterisation of OpenSim Moco's
``DeGrooteFregly2016Muscle``:

* tendon (S1): ``F~T = c1 exp(kT (l~T - c2)) - c3``, ``c1 = 0.2``, ``c2 = 0.995``, ``c3 = 0.25``, with
  ``kT = ln((1 + c3) / c1) / (1 + eps0 - c2)`` so that ``F~T = 1`` at the strain ``eps0 = 0.049`` (Moco's
  default ``tendon_strain_at_one_norm_force``; the paper's printed ``kT = 35`` puts it at 0.0474);
* fibre: the active force-length, force-velocity and passive curves of :mod:`.knee_hill` (the same paper), the
  passive one taken as zero below ``l~M = 1`` (as there) through a smooth maximum of width :data:`SMOOTH`, so that
  the NLP stays twice differentiable;
* geometry (constant-thickness pennation): ``l_M cos(alpha) = L_MT - l_T``, ``l_M sin(alpha) = l_opt sin(alpha_0)``;
  fibre velocity ``v_M = cos(alpha) (v_MT - v_T)``, normalised by ``v_max = 10 l_opt / s``;
* equilibrium: ``F~T = (a f_L(l~M) f_V(v~M) + f_PE(l~M)) cos(alpha)`` (the tendon carries what the fibre pulls
  along it).

Every function here works on floats, NumPy arrays and CasADi symbols alike.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from .knee_hill import E0, KPE, VMAX_PER_LOPT, active_force_length, force_velocity  # noqa: F401 (used here and re-exported)

C1, C2, C3 = 0.2, 0.995, 0.25          # tendon curve, De Groote et al. 2016 (S1)
TENDON_STRAIN = 0.049                  # strain at F0: Moco's DeGrooteFregly2016Muscle default
SMOOTH = 1e-4                          # width of the smooth max(0, f_PE): f_PE's error is below SMOOTH / 2


def _is_symbolic(*xs) -> bool:
    return any(isinstance(x, (ca.SX, ca.MX, ca.DM)) for x in xs)


def _exp(x):
    return ca.exp(x) if _is_symbolic(x) else np.exp(x)


def _log(x):
    return ca.log(x) if _is_symbolic(x) else np.log(x)


def _sqrt(x):
    return ca.sqrt(x) if _is_symbolic(x) else np.sqrt(x)


def _sin(x):
    return ca.sin(x) if _is_symbolic(x) else np.sin(x)


def tendon_stiffness(strain: float = TENDON_STRAIN) -> float:
    """``kT`` (dimensionless) that makes the tendon force ``F0`` at ``strain`` (Moco's formula)."""
    return math.log((1.0 + C3) / C1) / (1.0 + strain - C2)


def tendon_force(lT, strain: float = TENDON_STRAIN):
    """Normalized tendon force ``F~T`` at normalized tendon length ``l~T = l_T / l_s`` (eq. S1)."""
    return C1 * _exp(tendon_stiffness(strain) * (lT - C2)) - C3


def tendon_length(FT, strain: float = TENDON_STRAIN):
    """``l~T`` at the normalized tendon force ``F~T`` (> -c3): eq. S1 inverted."""
    return C2 + _log((FT + C3) / C1) / tendon_stiffness(strain)


def tendon_compliance(FT, strain: float = TENDON_STRAIN):
    """``d l~T / d F~T`` at ``F~T`` (per normalized force)."""
    return 1.0 / (tendon_stiffness(strain) * (FT + C3))


def passive_force_length(l):
    """De Groote et al. 2016 passive curve, zero below ``l = 1`` through a smooth maximum (width :data:`SMOOTH`)."""
    raw = (_exp(KPE * (l - 1.0) / E0) - 1.0) / (math.exp(KPE) - 1.0)
    return 0.5 * (raw + _sqrt(raw * raw + SMOOTH * SMOOTH))


def fibre_state(FT, dFT, L_mt, V_mt, l_opt, l_slack, alpha0, strain: float = TENDON_STRAIN):
    """Normalized fibre length and velocity and ``cos(alpha)`` from the tendon force ``F~T`` and its rate (1/s)
    and the unit's length ``L_mt`` (m) and rate ``V_mt`` (m/s)."""
    along = L_mt - l_slack * tendon_length(FT, strain)           # l_M cos(alpha)
    h = l_opt * _sin(alpha0)                                   # l_M sin(alpha), constant
    l_m = _sqrt(along * along + h * h)
    cos_a = along / l_m
    v_t = l_slack * tendon_compliance(FT, strain) * dFT
    v = cos_a * (V_mt - v_t) / (VMAX_PER_LOPT * l_opt)
    return l_m / l_opt, v, cos_a


def equilibrium_residual(a, FT, dFT, L_mt, V_mt, l_opt, l_slack, alpha0, strain: float = TENDON_STRAIN):
    """``F~T - (a f_L f_V + f_PE) cos(alpha)`` (normalized force): zero where fibre and tendon pull alike."""
    l, v, cos_a = fibre_state(FT, dFT, L_mt, V_mt, l_opt, l_slack, alpha0, strain)
    return FT - (a * active_force_length(l) * force_velocity(v) + passive_force_length(l)) * cos_a


def fibre_passive_force(FT, L_mt, l_opt, l_slack, alpha0, strain: float = TENDON_STRAIN):
    """The fibres' passive force along the tendon, ``f_PE(l~M) cos(alpha)`` (normalized), at tendon force ``F~T``."""
    l, _, cos_a = fibre_state(FT, 0.0, L_mt, 0.0, l_opt, l_slack, alpha0, strain)
    return passive_force_length(l) * cos_a


def static_tendon_force(a, L_mt, V_mt, l_opt, l_slack, alpha0, strain: float = TENDON_STRAIN, upper: float = 5.0,
                        iterations: int = 200) -> np.ndarray:
    """``F~T`` in equilibrium with activation ``a`` at the unit's length ``L_mt`` when the tendon's length does not
    change (``dF~T/dt = 0``: the fibre takes the whole ``V_mt``), by bisection on ``[0, upper]`` (NumPy arrays)."""
    args = np.broadcast_arrays(*(np.asarray(x, float) for x in (a, L_mt, V_mt, l_opt, l_slack, alpha0)))
    lo, hi = np.zeros_like(args[0]), np.full_like(args[0], upper)

    def g(FT):
        return equilibrium_residual(args[0], FT, 0.0, args[1], args[2], args[3], args[4], args[5], strain)

    for _ in range(iterations):        # the residual rises with F~T where the fibre shortens as the tendon stretches
        mid = 0.5 * (lo + hi)
        below = g(mid) < 0
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


__all__ = ["C1", "C2", "C3", "SMOOTH", "TENDON_STRAIN", "active_force_length", "equilibrium_residual",
           "fibre_passive_force", "fibre_state", "force_velocity", "passive_force_length", "static_tendon_force",
           "tendon_compliance", "tendon_force", "tendon_length", "tendon_stiffness"]
