"""Fits of the knee muscle paths to OpenSim's lengths *and* moment arms (issue 7; issue 15's preprocessing fix).

The force of a muscle acts on the coordinates through its moment arms, ``Q_c = r_c F``
(paper eqs. 35-41). For a path that is a taut string, virtual work gives ``r_c = -dL/dq_c``,
and a fit of the lengths alone gives the moment arms as its derivatives. OpenSim's wrapped
paths are not always such strings: the gastrocnemii wrap over an ellipsoid on the femur
and a cylinder on the tibia, their length has kinks where the wrapping switches, and
OpenSim's ``computeMomentArm`` (the generalized force of a unit tension, which is how
OpenSim applies the force) differs from ``-dL/dq`` by up to 25 mm in knee flexion.

So each muscle's *force path* ``P(q)`` is fitted so that ``-dP/dq`` reproduces OpenSim's
``computeMomentArm`` about every coordinate the path spans, with OpenSim's lengths as a
weak second target (they fix the constant and, where the two agree, the shape):

    min  sum_poses sum_c (s_c (dP/dq_c + r_c))^2  +  W^2 sum_poses (P - L)^2

``s_c = 1`` for rotations (rad; ``r`` in m) and ``s_c = LEVER`` for the knee translations
(``r`` is a share of the tension; a share error ``e`` moves the condyle forces as a frontal
moment-arm error ``e * LEVER`` would), ``W = LENGTH_WEIGHT`` per rad. Where OpenSim's
lengths and moment arms agree (every muscle but a few wrapped ones) both are met; where
they do not, the moment arms win, and the muscle-tendon unit keeps OpenSim's own length in
a separate fit (``unit_fits``, used for the fibre kinematics of the Hill model), as in
OpenSim, whose fibres follow the path length while its force acts through
``computeMomentArm``.

Basis: :func:`~.knee_muscles.exponents` (scaled coordinates). Samples where OpenSim's path
or moment arm jumps (residual above six times the median and above 1 mm) are dropped and
the fit repeated; their number is stored. The last 20 % of the poses are held out: the
stored ``holdout_*`` errors are measured there (moment arms: 95th percentile and maximum of
the absolute error over every finite OpenSim value, m or share of the tension).
"""
from __future__ import annotations

import numpy as np

from .knee_muscles import PRIMARY, SECONDARY, basis, exponents

LEVER = 0.022           # m, the condyles' frontal lever (contact points 22.6 / 22.2 mm from the femoral origin)
LENGTH_WEIGHT = 0.1     # 1 mm of length error weighs as 0.1 mm of moment-arm error
UNIT_TOLERANCE = 1e-3   # m: a force path whose fitted length is off OpenSim's by more gets its own unit-length fit
TRANSLATIONS = ("knee_tx", "knee_ty", "knee_tz")


def basis_gradient(Z: np.ndarray, E: np.ndarray, j: int) -> np.ndarray:
    """``d/dz_j`` of the monomials ``prod_i z_i^E[k, i]`` at the rows of ``Z`` (samples x monomials)."""
    Ej = E.copy()
    coef = Ej[:, j].astype(float)
    Ej[:, j] = np.maximum(Ej[:, j] - 1, 0)
    return coef[None, :] * np.prod(Z[:, None, :] ** Ej[None, :, :], axis=2)


def _lstsq(A, b):
    # Householder QR: the monomials of scaled coordinates are well conditioned enough, and it is
    # several times faster than the SVD of np.linalg.lstsq on these tall matrices
    # (R of [A b] holds Q^T b in its last column, so Q itself is never formed)
    n = A.shape[1]
    Rm = np.linalg.qr(np.column_stack([A, b]), mode="r")
    return np.linalg.solve(Rm[:n, :n], Rm[:n, n])


def _robust_lstsq(A, b, groups, floors, rounds=3):
    """Least squares, dropping rows whose residual exceeds ``max(6 median, floor)`` within their group.

    Rows with a non-finite target (OpenSim's ``computeMomentArm`` returns NaN where a wrap fails,
    e.g. the first gluteus maximus bundle and the piriformis at a few poses) are never used."""
    finite = np.isfinite(b)
    keep = finite.copy()
    b = np.where(finite, b, 0.0)
    for _ in range(rounds):
        coef = _lstsq(A[keep], b[keep])
        res = np.abs(A @ coef - b)
        keep = finite.copy()
        for g, floor in zip(groups, floors):
            keep[g] &= res[g] <= max(6 * np.median(res[g][finite[g]]), floor)
    return coef, keep


def _inliers(err, floor):
    ok = np.isfinite(err)
    return ok & (np.abs(np.where(ok, err, 0.0)) <= max(6 * np.median(np.abs(err[ok])), floor))


def fit_length_only(X, y, spans, names, centre, half, n_fit) -> dict:
    """Least-squares fit of one sampled length ``y`` over the coordinates in ``spans`` (lengths only)."""
    prim = [c for c in PRIMARY if c in spans]
    sec = [c for c in SECONDARY if c in spans]
    cols = [names.index(c) for c in prim + sec]
    E = exponents(len(prim), len(sec))
    B = basis((X[:, cols] - centre[cols]) / half[cols], E)
    coef, keep = _robust_lstsq(B[:n_fit], y[:n_fit], [np.arange(n_fit)], [1e-3])
    err = B[n_fit:] @ coef - y[n_fit:]
    good = _inliers(err, 1e-3)
    return {"coordinates": prim + sec, "exponents": E.tolist(), "coefficients": coef.tolist(),
            "centre": centre[cols].tolist(), "half_range": half[cols].tolist(),
            "holdout_max_length_error_m": float(np.abs(err[good]).max()),
            "holdout_outliers": int((~good).sum()), "fit_outliers_dropped": int(n_fit - keep.sum())}


def fit_force_path(X, y, arm_rows, arms, spans, names, centre, half, n_fit) -> dict:
    """Joint fit of one muscle's force path to OpenSim's lengths ``y`` (all poses) and moment arms
    ``arms`` (``arm_rows`` poses x spanned coordinates, in the order of ``names``); module docstring."""
    prim = [c for c in PRIMARY if c in spans]
    sec = [c for c in SECONDARY if c in spans]
    coords = prim + sec
    cols = [names.index(c) for c in coords]
    E = exponents(len(prim), len(sec))
    Z = (X[:, cols] - centre[cols]) / half[cols]
    B = basis(Z, E)
    arm_order = [c for c in names if c in spans]            # column order of ``arms`` (OpenSim script)
    rows = np.asarray(arm_rows, int)
    fit_r, hold_r = rows < n_fit, rows >= n_fit
    scale = {c: (LEVER if c in TRANSLATIONS else 1.0) for c in coords}
    G = {c: basis_gradient(Z[rows], E, j) / half[cols[j]] for j, c in enumerate(coords)}   # dP/dq_c per coefficient
    A_blocks, b_blocks, groups, floors, start = [LENGTH_WEIGHT * B[:n_fit]], [LENGTH_WEIGHT * y[:n_fit]], [], [], n_fit
    groups.append(np.arange(n_fit))
    floors.append(LENGTH_WEIGHT * 1e-3)
    for c in coords:
        r = np.asarray(arms)[:, arm_order.index(c)]
        A_blocks.append(scale[c] * G[c][fit_r])
        b_blocks.append(-scale[c] * r[fit_r])
        n = int(fit_r.sum())
        groups.append(np.arange(start, start + n))
        floors.append(1e-3)
        start += n
    coef, keep = _robust_lstsq(np.vstack(A_blocks), np.concatenate(b_blocks), groups, floors)
    not_finite = int((~np.isfinite(np.asarray(arms, float))).sum())
    err_L = B[n_fit:] @ coef - y[n_fit:]
    good_L = _inliers(err_L, 1e-3)
    arm_err = {}
    for c in coords:   # every finite held-out value counts (no outlier is removed from the check)
        e = -(G[c][hold_r] @ coef) - np.asarray(arms, float)[hold_r, arm_order.index(c)]
        e = np.abs(e[np.isfinite(e)])
        arm_err[c] = {"p95": float(np.percentile(e, 95)), "max": float(e.max()), "n": int(len(e))} if len(e) else None
    return {"coordinates": coords, "exponents": E.tolist(), "coefficients": coef.tolist(),
            "centre": centre[cols].tolist(), "half_range": half[cols].tolist(),
            "fitted_to": "lengths and computeMomentArm",
            "holdout_max_length_error_m": float(np.abs(err_L[good_L]).max()),
            "holdout_moment_arm_error": arm_err,
            "holdout_outliers": int((~good_L).sum()), "fit_outliers_dropped": int((~keep).sum()),
            "opensim_moment_arms_not_finite": not_finite}


def _scaling(X):
    lo, hi = X.min(0), X.max(0)
    return (lo + hi) / 2, np.maximum((hi - lo) / 2, 1e-12), int(0.8 * len(X))   # last 20 % held out


def fit_paths(raw: dict) -> dict:
    """The force paths of ``raw["muscles"]`` (``raw`` from :mod:`.knee_paths_opensim`): jointly fitted to
    lengths and ``computeMomentArm`` when ``raw`` has the moment arms, else to the lengths alone."""
    names = raw["coordinates"]
    X, L = np.asarray(raw["samples"]), np.asarray(raw["lengths"])
    centre, half, n_fit = _scaling(X)
    if "moment_arms" not in raw:
        return {m: fit_length_only(X, L[:, i], raw["spans"][m], names, centre, half, n_fit)
                for i, m in enumerate(raw["muscles"])}
    return {m: fit_force_path(X, L[:, i], raw["arm_indices"], raw["moment_arms"][m]["values"], raw["spans"][m],
                              names, centre, half, n_fit) for i, m in enumerate(raw["muscles"])}


def fit_units(raw: dict, fits: dict | None = None) -> dict:
    """Fits of the muscle-tendon-unit lengths where they differ from the force paths (``fits``).

    The quadriceps (``raw["units"]``): their force paths run on over the patella to the tibia;
    their units are the model's twins ``<name>_withreallength`` ending on the patella, which the
    model's ``optimal_fiber_length`` and ``tendon_slack_length`` describe. Any other muscle whose
    force path, fitted to the moment arms, misses OpenSim's length by more than
    :data:`UNIT_TOLERANCE` at the held-out poses keeps OpenSim's length here (module docstring).
    """
    names = raw["coordinates"]
    X = np.asarray(raw["samples"])
    centre, half, n_fit = _scaling(X)
    LU = np.asarray(raw.get("unit_lengths", np.zeros((0, 0))))
    out = {m: fit_length_only(X, LU[:, i], raw["unit_spans"][m], names, centre, half, n_fit)
           for i, m in enumerate(raw.get("units", []))}
    L = np.asarray(raw["lengths"])
    for i, m in enumerate(raw["muscles"]):
        if m not in out and fits is not None and fits[m]["holdout_max_length_error_m"] > UNIT_TOLERANCE:
            out[m] = fit_length_only(X, L[:, i], raw["spans"][m], names, centre, half, n_fit)
    return out
