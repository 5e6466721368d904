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
        # Lagrange basis l_j(s) = prod_{m != j} (s - x_m) / (x_j - x_m), all j at once: the product
        # over m of a (rows x j x m) array whose diagonal m = j is one.
        num = s[:, None, None] - nodes[None, None, :]
        den = nodes[:, None] - nodes[None, :]
        eye = np.eye(len(idx), dtype=bool)
        ratio = np.where(eye[None], 1.0, num / np.where(eye, 1.0, den)[None])
        E[rows[:, None], idx[None, :]] = ratio.prod(axis=2)
    return E
