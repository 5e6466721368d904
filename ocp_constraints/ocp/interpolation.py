"""Values between collocation points: each interval's Lagrange polynomial through its points.

One matrix ``E`` maps the values at every point of a transcription to values at any normalized
times, ``values(fractions) = E @ point_values``; an hp mesh (each interval its own degree) needs no
special case. Used by :meth:`OCPSolution.interpolate`, warm starts on another mesh and the error
estimate (:mod:`ocp_constraints.ocp.error_estimate`).
"""
from __future__ import annotations

import numpy as np


def interpolation_matrix(transcription, fractions) -> np.ndarray:
    """``E`` (``len(fractions) x points``) at normalized times ``fractions`` in ``[0, 1]``."""
    tr = transcription
    fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
    mesh = tr.scheme.mesh_fractions
    k_of = np.clip(np.searchsorted(mesh, fractions, side="right") - 1, 0, tr.scheme.intervals - 1)
    E = np.zeros((len(fractions), tr.layout.n_points))
    for k in np.unique(k_of):
        rows = np.flatnonzero(k_of == k)
        idx = np.asarray(tr.interval_points(k))
        nodes, s = tr.fractions[idx], fractions[rows]
        for j in range(len(idx)):
            others = np.delete(nodes, j)
            E[rows, idx[j]] = np.prod((s[:, None] - others[None, :]) / (nodes[j] - others[None, :]), axis=1)
    return E
