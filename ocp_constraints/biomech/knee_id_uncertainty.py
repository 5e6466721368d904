"""Uncertainty of the inverse dynamics' hip moments from the hip joint centre's location error (issue 15, C19).

Inverse dynamics takes the hip moment about the model's hip joint centre (HJC). A centre off by ``dr`` changes the
moment the pelvis exerts on the femur, to first order, by ``dM = -dr x F`` (``F`` the force the pelvis exerts on the
femur: the hip's load channel, Lagrange's prescription of its multipliers, paper eq. 26). The hip generalized force
of coordinate ``c`` is ``Q_c = e_c . M`` with ``e_c = d omega_femur / d qdot_c`` (paper eqs. 38-41), so
``dQ_c = -dr . (F x e_c)`` and, for ``dr`` isotropic Gaussian with standard deviation ``s`` per axis,

    sigma_c(t) = s |e_c(t) x F(t)|                                          (N m).

Combined in quadrature with ``sigma_0`` (every other error, today's uniform reserve weight read as C18 reads it,
:func:`.knee_static.reserve_weights_from_sigma`) it gives per-frame, per-row reserve weights
``w_c(t) = 1 / (2 (sigma_c(t)^2 + sigma_0^2))``, ``sigma_0 = 1/sqrt(2)`` N m, for :func:`.knee_static.solve_static` and
:func:`.knee_collocation.solve_collocation` (``results/knee/preregistration.md``, seventh round).

Conversions of published HJC errors (3D distances) to ``s``: the distance of an isotropic 3D Gaussian error is
``s`` times a chi variable with 3 degrees of freedom: 95% quantile :data:`CHI3_95` ``s``, mean :data:`CHI3_MEAN` ``s``.
"""
from __future__ import annotations

import numpy as np

from ..errors import KneeError
from .knee_static import RESERVE_WEIGHT, RESERVED

HIP_ROWS = ("hip_flexion", "hip_adduction", "hip_rotation")
CHI3_95 = 2.7954834829151074          # sqrt(chi2_3 quantile 0.95): 95% radius / s of an isotropic 3D Gaussian
CHI3_MEAN = 2.0 * np.sqrt(2.0 / np.pi)  # mean distance / s of an isotropic 3D Gaussian
SIGMA_0 = 1.0 / np.sqrt(2.0)          # N m: today's uniform weight w = 1 read as w = 1/(2 sigma^2)
# s (m) from the literature, preregistered (seventh round): the primary value and the reported-only ones
S_BELL_1989 = 0.026 / CHI3_95         # Bell, Brand, Pedersen 1989, Hum Mov Sci 8:3-16: best predictive, 95% in 2.6 cm
S_TYLKOWSKI = 0.033 / CHI3_95         # same paper, Tylkowski's method: 95% within 3.3 cm
S_HARRINGTON = 0.0123 / CHI3_MEAN     # Mantovani, Ng, Lamontagne 2016, Gait Posture 44:48-54: mean 12.3 mm vs CT
S_DAVIS = 0.0250 / CHI3_MEAN          # same paper, Davis's method: mean 25.0 mm vs CT


def hjc_moment_sigma(force, axes, s: float) -> np.ndarray:
    """``sigma_c = s |e_c x F|`` (N m) per frame and axis: ``force`` (frames x 3, N), ``axes`` (frames x rows x 3,
    unit vectors in the same frame as ``force``), ``s`` the HJC error's standard deviation per axis (m)."""
    s = float(s)
    if not (np.isfinite(s) and s >= 0.0):
        raise KneeError(f"hip joint centre error s = {s!r}: a standard deviation must be a finite number >= 0 (m)")
    F = np.asarray(force, float)
    E = np.asarray(axes, float)
    if F.ndim != 2 or F.shape[1] != 3 or E.ndim != 3 or E.shape[2] != 3 or E.shape[0] != F.shape[0]:
        raise KneeError(f"hjc_moment_sigma: force must be frames x 3 and axes frames x rows x 3, got "
                        f"{F.shape} and {E.shape}")
    return s * np.linalg.norm(np.cross(E, F[:, None, :]), axis=2)


def hip_force_and_axes(gait, joint: str = "hip", coordinates=HIP_ROWS) -> tuple[np.ndarray, np.ndarray]:
    """The force the pelvis exerts on the femur (frames x 3, N, ground frame) and the coordinates' rotation axes
    ``e_c = d(omega_child - omega_parent)/d qdot_c`` (frames x rows x 3, ground frame) of a gait result
    (:func:`ocp_constraints.biomech.gait.run_inverse_dynamics`).

    Checked (``tests/test_knee_id_uncertainty.py``): ``F`` is the leg's Newton balance ``sum m (a - g)`` less the
    ground reaction, and ``e_c`` projects the leg's moment about the hip centre onto the ID's ``Q_c``.
    """
    if joint not in gait.joints:
        raise KneeError(f"no joint '{joint}' in the gait result (joints: {', '.join(gait.joints)})")
    info = gait.joints[joint]
    names = gait.coordinate_names
    missing = [c for c in coordinates if c not in names]
    if missing:
        raise KneeError(f"joint '{joint}': no coordinate(s) {missing} in the gait result")
    loads = gait.loads()
    F = np.column_stack([loads[f"{joint}@{info.child}.F_{a}"] for a in "xyz"])
    bodies = list(gait.functions.meta["bodies"])
    J = gait.states["J"]                              # frames x 6 n_bodies x coordinates: d(vbar, omega)/d(pdot)
    kc, cols = bodies.index(info.child), [names.index(c) for c in coordinates]
    E = J[:, 6 * kc + 3:6 * kc + 6, :][:, :, cols]
    if info.parent in bodies:                         # relative angular velocity (the pelvis moves too)
        kp = bodies.index(info.parent)
        E = E - J[:, 6 * kp + 3:6 * kp + 6, :][:, :, cols]
    return F, E.transpose(0, 2, 1)


def hjc_sigma(gait, s: float, joint: str = "hip", coordinates=HIP_ROWS) -> np.ndarray:
    """``sigma_c(t) = s |e_c x F_hip|`` (frames x rows, N m) of a gait result; ``s`` in m."""
    F, E = hip_force_and_axes(gait, joint, coordinates)
    return hjc_moment_sigma(F, E, s)


def reserve_weights_per_frame(sigma: dict, base_weight: float = RESERVE_WEIGHT) -> np.ndarray:
    """Reserve weights (frames x :data:`.knee_static.RESERVED`, per (N m)^2): ``1 / (2 (sigma_c(t)^2 + sigma_0^2))``
    on the rows named in ``sigma`` (name -> per-frame N m), ``base_weight`` on the others, where
    ``sigma_0^2 = 1 / (2 base_weight)`` (the other errors, in quadrature; the default :data:`SIGMA_0`). All
    ``sigma_c = 0`` give ``base_weight`` exactly (today's problem with the default)."""
    if not sigma:
        raise KneeError("reserve_weights_per_frame: no row given (sigma maps a reserved coordinate to its "
                        "per-frame standard deviation, N m)")
    w0 = float(base_weight)
    if not (np.isfinite(w0) and w0 > 0.0):
        raise KneeError(f"base_weight = {base_weight!r}: must be a finite number > 0 (per (N m)^2), else a force "
                        "along an axis would make that balance infinitely dear")
    values = {k: np.atleast_1d(np.asarray(v, float)) for k, v in sigma.items()}
    n = {v.shape for v in values.values()}
    if len(n) != 1 or next(iter(n)).__len__() != 1:
        raise KneeError(f"reserve_weights_per_frame: every row needs one value per frame, got shapes {sorted(n)}")
    w = np.full((next(iter(values.values())).size, len(RESERVED)), w0)
    for name, v in values.items():
        if name not in RESERVED:
            raise KneeError(f"reserve uncertainty for '{name}': no reserve on that coordinate "
                            f"(use one of {', '.join(RESERVED)})")
        if not np.all(np.isfinite(v) & (v >= 0.0)):
            raise KneeError(f"reserve uncertainty for '{name}': standard deviations must be finite and >= 0 (N m)")
        w[:, RESERVED.index(name)] = 1.0 / (2.0 * v * v + 1.0 / w0)     # = 1 / (2 (sigma^2 + sigma_0^2))
    return w
