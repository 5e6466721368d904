"""Smoothness read from a solution's own Legendre coefficients, per mesh interval (issue 19).

A polynomial through an interval's points has Legendre coefficients that fall geometrically where the
solution is smooth and resolved, and stay near a step's where it jumps or kinks inside the interval
(Liu, Hager and Rao 2015; Patterson and Rao 2014 read the same decay to choose between raising the
degree and splitting). Two readings, neither needing an NLP (the coefficients are a linear map of the
point values): :func:`legendre_decay` (is an interval smooth: the hp rule's "rough" and the withdrawal of a
met estimate, :mod:`.nonsmooth`) and :func:`predicted_error` (how large is its error: the pilot's size,
:mod:`.mesh_companions`). The error estimate itself is :mod:`.error_estimate`'s companion difference.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial import legendre

from .error_estimate import names

# An interval whose inputs' or multipliers' last Legendre coefficient, over their largest after the
# mean, is above this fraction of what a unit step between two of its points gives at the least
# (:func:`_step_ratio`), is not smooth. A jump's coefficients do not fall (a step: 0.52 of the
# largest at degree 3, 0.20 at degree 9); a resolved smooth arc's fall geometrically (swing-up at
# 1e-4: at most 0.015 of the step's). Half the step's: no jump passes, a mildly curved degree-3
# interval does (the rolling-disk drive at 1e-3: 0.23 of the step's).
DECAY_LIMIT = 0.5
# Components whose coefficients after the mean are all below this (relative to the quantity's
# largest value) are constant on the interval: their ratios are round-off, not a decay.
NEGLIGIBLE = 1e-6


def _step_ratio(to_coefficients: np.ndarray) -> float:
    """The smallest ``|a_last| / max_{j >= 1} |a_j|`` of a unit step between any two of the points
    (``to_coefficients``: point values to Legendre coefficients): what a jump gives at the least,
    0.52 at degree 3 down to 0.20 at degree 9 (a smooth ``exp(x)`` on the interval: 0.39 and 1e-4)."""
    n = to_coefficients.shape[1]
    steps = (np.arange(n)[None, :] >= np.arange(1, n)[:, None]).astype(float)     # step after point s
    a = np.abs(steps @ to_coefficients.T)
    return float((a[:, -1] / a[:, 1:].max(axis=1)).min())


def legendre_decay(solution, companion=None) -> tuple[np.ndarray, np.ndarray]:
    """Per interval, the largest over the inputs and over the multipliers of ``max |a_last| / max_{j >= 1} |a_j|``
    (maxima over the quantity's components, in its relative scale) divided by that of a unit step
    (:func:`_step_ratio`), ``a_j`` the Legendre coefficients of the solution's polynomial through the
    interval's collocation points; and that ``max |a_last|``
    (the size of the polynomial's last term, relative to the quantity's largest value). Needs no
    NLP: the coefficients are a linear map of the point values.

    Where the solution is smooth and resolved, the coefficients fall geometrically and this is small;
    where the inputs or multipliers jump inside the interval (a switch), it stays near one, at any
    degree: there a comparison with a higher degree (the companion of :func:`estimate_error`), which
    resolves the jump no better, is not an upper bound of the error (Liu, Hager and Rao 2015 use the
    same decay to tell smooth intervals from non-smooth ones). States are left out: at a switch of a
    bang-bang input they are continuous with their first derivative, and their coefficients fall.

    ``companion`` (the solution's companion, on the same mesh at higher degrees or on a finer one): an interval is
    read as not smooth only where the companion's intervals over it are not smooth either (the smaller of the two
    readings). A jump's coefficients do not fall at any degree, so the companion sees it too; a smooth arc's fall
    once there are enough of them, and three are not: a sixth newcomer's pendulum tracking a steep reference, its
    hinge force turning with the rod on degree-3 intervals, read 0.64-1.74 of a step's where nothing switches, and
    "met" was withdrawn at 1e-4 with its estimate a bound (``results/bench/refinement_newcomer6.md``, finding 1)."""
    if companion is not None:
        own, tail = legendre_decay(solution)
        theirs = legendre_decay(companion)[0]
        mesh, other = solution.transcription.scheme.mesh_fractions, companion.transcription.scheme.mesh_fractions
        seen = np.array([theirs[(other[:-1] < b) & (other[1:] > a)].max(initial=0.0) for a, b in zip(mesh[:-1], mesh[1:])])
        return np.minimum(own, seen), tail
    tr = solution.transcription
    labels = names(solution)
    out, tail = np.zeros(tr.scheme.intervals), np.zeros(tr.scheme.intervals)
    mesh = tr.scheme.mesh_fractions
    # Intervals of one local scheme share the map from point values to coefficients (their points in
    # local time are the same): one matrix per degree, all their intervals at once.
    local_of = np.array([tr.local[k].label for k in range(tr.scheme.intervals)])
    for q in ("inputs", "multipliers"):
        values = np.array([solution.sample(n) for n in labels[q]], float).reshape(len(labels[q]), len(solution.t))
        scale = float(np.abs(values[:, 1:]).max()) if values.shape[1] > 1 and values.size else 0.0
        if scale == 0.0:
            continue
        for label in np.unique(local_of):
            ks = np.flatnonzero(local_of == label)
            p = len(tr.interval_points(ks[0]))
            if p < 4:           # fewer than 3 collocation points: no decay to read
                continue
            # Radau's inputs and multipliers at an interval's first point belong to the interval
            # before (its last collocation point): the fit uses the interval's own points.
            idx = tr.offsets[ks][:, None] + np.arange(1, p)[None, :]
            x = 2.0 * (tr.fractions[idx[0]] - mesh[ks[0]]) / (mesh[ks[0] + 1] - mesh[ks[0]]) - 1.0
            to_coefficients = np.linalg.inv(legendre.legvander(x, p - 2))
            a = np.abs(np.einsum("jp,ckp->kjc", to_coefficients, values[:, idx])) / scale   # interval x j x component
            # Tail over the largest variation of any component (one scale for the quantity): a small
            # component's round-off is not read as a slow decay.
            body = a[:, 1:, :].max(axis=(1, 2))
            last = a[:, -1, :].max(axis=1)
            ratio = np.where(body > NEGLIGIBLE, last / np.maximum(body, NEGLIGIBLE), 0.0) / _step_ratio(to_coefficients)
            worse = ratio > out[ks]
            out[ks[worse]], tail[ks[worse]] = ratio[worse], last[worse]
    return out, tail


def predicted_error(solution) -> tuple[np.ndarray, np.ndarray]:
    """Per interval, the error of the solution's polynomials that their own Legendre coefficients predict,
    before any companion is solved: the next coefficient, extrapolated geometrically from the last two,
    ``|a_d| min(1, |a_d| / |a_{d-1}|)`` (maxima over the components; states absolute through the interval's
    points, multipliers relative to their largest value through its collocation points), the larger of the
    two; and whether both fall there (``|a_d| < |a_{d-1}|``). The geometric fall is what hp theory assumes
    of a smooth, resolved solution (Patterson and Rao 2014, Liu, Hager and Rao 2015); where the
    coefficients do not fall (a coarse mesh that does not resolve the solution: the suite's acrobot and
    cart double pendulum on 10 intervals of degree 3, rates up to 1.6-1.9), the prediction means nothing.
    Used only to size the pilot
    (:func:`.mesh_companions.pilot_pieces`), never as the estimate: on the first mesh (Radau 3, 10 intervals)
    the pilot's estimate per interval is 0.08-0.38x the last coefficient alone on the swing-up, 1.1-460x on the
    suite's acrobot, cart double pendulum and four-bar (``python scripts/mesh_refinement_costs.py`` reads the
    same ratio on other meshes): a prediction, good to a factor that the pieces it asks for, about its
    seventh root, mostly absorb."""
    tr = solution.transcription
    labels = names(solution)
    mesh = tr.scheme.mesh_fractions
    out, falls = np.zeros(tr.scheme.intervals), np.ones(tr.scheme.intervals, bool)
    for q in ("states", "multipliers"):
        values = np.array([solution.sample(n) for n in labels[q]], float).reshape(len(labels[q]), len(solution.t))
        scale = 1.0 if q == "states" else (float(np.abs(values[:, 1:]).max()) if values.size else 0.0)
        if not values.size or scale == 0.0:
            continue
        first = 0 if q == "states" else 1       # multipliers: the interval's own (collocation) points
        for k in range(tr.scheme.intervals):
            idx = np.asarray(tr.interval_points(k))[first:]
            if len(idx) < 3:
                continue
            x = 2.0 * (tr.fractions[idx] - mesh[k]) / (mesh[k + 1] - mesh[k]) - 1.0
            a = np.abs(np.linalg.solve(legendre.legvander(x, len(idx) - 1), values[:, idx].T)).max(axis=1) / scale
            rate = a[-1] / a[-2] if a[-2] > 0 else np.inf
            falls[k] &= rate < 1.0
            out[k] = max(out[k], a[-1] * min(rate, 1.0))
    return out, falls

