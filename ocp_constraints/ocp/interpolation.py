"""Values between collocation points: each interval's Lagrange polynomial through its points.

One matrix ``E`` maps the values at every point of a transcription to values at any normalized
times, ``values(fractions) = E @ point_values``; an hp mesh (each interval its own degree) needs no
special case. Used by :meth:`OCPSolution.interpolate`, warm starts on another mesh and the error
estimate (:mod:`ocp_constraints.ocp.error_estimate`). Inputs and multipliers that jump at a mesh point
are read from the interval's own points after it (:func:`jumps_at_starts`, ``algebraic``).
"""
from __future__ import annotations

import numpy as np

from .schemes import Radau


def lagrange_basis(nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``l_j(s_r)`` (``len(s) x len(nodes)``), the Lagrange basis through ``nodes``:
    ``prod_{m != j} (s - x_m) / (x_j - x_m)``, all at once (the diagonal ``m = j`` set to one)."""
    eye = np.eye(len(nodes), dtype=bool)
    den = np.where(eye, 1.0, nodes[:, None] - nodes[None, :])
    num = s[:, None, None] - nodes[None, None, :]
    return np.where(eye[None], 1.0, num / den[None]).prod(axis=2)


def interval_of(transcription, fractions, ending: bool = False) -> np.ndarray:
    """The mesh interval of each normalized time. A mesh point: the interval it starts, or with ``ending``
    the one it ends (whose last collocation point it is); 0 and 1: the first and the last."""
    mesh = transcription.scheme.mesh_fractions
    side = "left" if ending else "right"
    return np.clip(np.searchsorted(mesh, fractions, side=side) - 1, 0, transcription.scheme.intervals - 1)


def starts_shared(transcription) -> np.ndarray:
    """Per interval: whether its start is the previous interval's last collocation point (a Radau interval after the
    first), so that an input or multiplier there is that interval's value, not its own."""
    tr = transcription
    return np.array([k > 0 and isinstance(tr.local[k], Radau) for k in range(tr.scheme.intervals)], bool)


def jumps_at_starts(transcription, values: np.ndarray) -> np.ndarray:
    """Per interval: whether ``values`` (one per point: an input or a multiplier) jump at its start
    (by more than 1e-6 of their largest size: below that both readings agree to as much).

    A Radau interval's start carries the previous interval's last collocation value. Where the quantity is
    smooth there, that value is the most accurate of all (order ``2d - 1`` at mesh points) and the
    polynomial through it is the better one. Where it jumps there (a bang-bang input switching at a mesh
    point), the interval's own polynomial, extrapolated to its start, misses that value by the jump. The
    test: the miss exceeds the spread of the interval's own values (a jump between bounds: the whole jump
    against a spread of zero; a smooth quantity: the polynomial's error, far below its change over the
    interval)."""
    tr = transcription
    values = np.asarray(values, dtype=float)
    out = np.zeros(tr.scheme.intervals, bool)
    floor = 1e-6 * float(np.abs(values).max(initial=0.0))
    mesh = tr.scheme.mesh_fractions
    shared = starts_shared(tr)
    labels = np.array([tr.local[k].label for k in range(len(out))])
    for label in set(labels[shared]):           # intervals of one degree share their local nodes: one basis
        ks = np.flatnonzero(shared & (labels == label))
        idx = np.asarray(tr.interval_points(int(ks[0])))
        nodes = (tr.fractions[idx] - mesh[ks[0]]) / (mesh[ks[0] + 1] - mesh[ks[0]])
        weights = lagrange_basis(nodes[1:], np.zeros(1))[0]
        own = values[tr.offsets[ks][:, None] + np.arange(1, len(idx))[None, :]]
        miss = np.abs(own @ weights - values[tr.offsets[ks]])
        out[ks] = miss > np.maximum(np.ptp(own, axis=1), floor)
    return out


def imposed_jumps(transcription) -> dict[float, str]:
    """Where two imposed arcs of one input meet (fraction of the horizon -> the input): a bang-bang input's jumps, free
    mesh points whose times the NLP places (:mod:`.jump_arcs`). Each side of one is its own interval's polynomial,
    exact there; the inputs and multipliers have two values at it."""
    arcs = getattr(transcription, "arcs", ())
    return {a.end: a.quantity for a in arcs for b in arcs if a.quantity == b.quantity and abs(a.end - b.start) <= 1e-9}


def starts_at_imposed_jumps(transcription) -> np.ndarray:
    """Per interval: whether it starts at an imposed jump (:func:`imposed_jumps`)."""
    mesh, at = transcription.scheme.mesh_fractions, np.array(list(imposed_jumps(transcription)), float)
    out = np.zeros(transcription.scheme.intervals, bool)
    if at.size:
        out[1:] = np.abs(mesh[1:-1, None] - at[None, :]).min(axis=1) <= 1e-9
    return out


def interpolation_matrix(transcription, fractions, algebraic=False, intervals=None) -> np.ndarray:
    """``E`` (``len(fractions) x points``) at normalized times ``fractions`` in ``[0, 1]``.

    ``algebraic`` (inputs and multipliers): on a Radau interval after the first, the polynomial through
    the interval's own collocation points only, not its start, and a mesh point read as the end of the
    interval it closes (its value is that interval's). That start is the previous interval's last collocation
    point: the dynamics there belong to that interval, and an input or multiplier that jumps at the
    mesh point is exact on both sides only this way (through the start, a bang-bang torque read +0.53
    where every point of the interval held -1). The states are continuous and keep the start.

    ``algebraic`` may also be one flag per interval (read so there only), and ``intervals`` the interval whose
    polynomial reads each time (default: the one it lies in), so that a time at a mesh point reads the limit from
    the side asked (:func:`.error_estimate.values_at`).
    """
    tr = transcription
    fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
    mesh = tr.scheme.mesh_fractions
    per_interval = np.broadcast_to(np.asarray(algebraic, dtype=bool), (tr.scheme.intervals,))
    k_of = interval_of(tr, fractions, ending=algebraic is True) if intervals is None else np.asarray(intervals)
    E = np.zeros((len(fractions), tr.layout.n_points))
    # Intervals of one local scheme share their nodes in local time (0 at the interval's start, 1 at
    # its end): one basis evaluation for all their rows (a loop per interval cost ~3 ms a matrix).
    # Those whose start is read alike share one basis; with ``algebraic`` an interval whose start
    # is the previous one's (:func:`starts_shared`) leaves it out.
    own = starts_shared(tr) & per_interval
    keys = [(tr.local[k].label, bool(own[k])) for k in range(tr.scheme.intervals)]
    groups: dict[tuple[str, bool], int] = {}
    for k, key in enumerate(keys):
        groups.setdefault(key, k)
    key_of = np.array([groups[key] for key in keys])
    for first in np.unique(key_of[k_of]):
        rows = np.flatnonzero(key_of[k_of] == first)
        k = k_of[rows]
        idx0 = np.asarray(tr.interval_points(int(first)))
        nodes = (tr.fractions[idx0] - mesh[first]) / (mesh[first + 1] - mesh[first])
        local = (fractions[rows] - mesh[k]) / (mesh[k + 1] - mesh[k])
        cols = tr.offsets[k][:, None] + np.arange(len(idx0))[None, :]
        if own[first]:
            nodes, cols = nodes[1:], cols[:, 1:]
        E[rows[:, None], cols] = lagrange_basis(nodes, local)
    return E
