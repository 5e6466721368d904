"""Values between collocation points: each interval's Lagrange polynomial through its points.

One matrix ``E`` maps the values at every point of a transcription to values at any normalized
times, ``values(fractions) = E @ point_values``; an hp mesh (each interval its own degree) needs no
special case. Used by :meth:`OCPSolution.interpolate`, warm starts on another mesh and the error
estimate (:mod:`ocp_constraints.ocp.error_estimate`).
"""
from __future__ import annotations

import numpy as np


def lagrange_basis(nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``l_j(s_r)`` (``len(s) x len(nodes)``), the Lagrange basis through ``nodes``:
    ``prod_{m != j} (s - x_m) / (x_j - x_m)``, all at once (the diagonal ``m = j`` set to one)."""
    eye = np.eye(len(nodes), dtype=bool)
    den = np.where(eye, 1.0, nodes[:, None] - nodes[None, :])
    num = s[:, None, None] - nodes[None, None, :]
    return np.where(eye[None], 1.0, num / den[None]).prod(axis=2)


def interpolation_matrix(transcription, fractions) -> np.ndarray:
    """``E`` (``len(fractions) x points``) at normalized times ``fractions`` in ``[0, 1]``."""
    tr = transcription
    fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
    mesh = tr.scheme.mesh_fractions
    k_of = np.clip(np.searchsorted(mesh, fractions, side="right") - 1, 0, tr.scheme.intervals - 1)
    E = np.zeros((len(fractions), tr.layout.n_points))
    # Intervals of one local scheme share their nodes in local time (0 at the interval's start, 1 at
    # its end): one basis evaluation for all their rows (a loop per interval cost ~3 ms a matrix).
    local_of = np.array([tr.local[k].label for k in range(tr.scheme.intervals)])
    for label in np.unique(local_of[k_of]):
        rows = np.flatnonzero(local_of[k_of] == label)
        k = k_of[rows]
        first = int(np.flatnonzero(local_of == label)[0])
        idx0 = np.asarray(tr.interval_points(first))
        nodes = (tr.fractions[idx0] - mesh[first]) / (mesh[first + 1] - mesh[first])
        local = (fractions[rows] - mesh[k]) / (mesh[k + 1] - mesh[k])
        cols = tr.offsets[k][:, None] + np.arange(len(idx0))[None, :]
        E[rows[:, None], cols] = lagrange_basis(nodes, local)
    return E
