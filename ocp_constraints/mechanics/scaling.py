"""Rank decisions free of the units: a Jacobian's columns are in the units of its coordinates or speeds (m, rad;
m/s, rad/s), its rows in those of its constraints, and a rank read off the raw singular values depends on them."""
from __future__ import annotations

import numpy as np


def equilibrated(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A`` with each column, then each row, divided by its largest entry, and the columns' divisors.

    The rank and which rows combine are unchanged; the null space is the scaled one's rows divided by the columns'
    divisors. The singular values no longer depend on the units: a rod of 100 km had its angle columns 5e4 times
    its position columns, singular values from 5e4 down to 2e-5, and a full-rank Jacobian was called rank-deficient
    (its hinge's constraints "redundant", its initial position "not determined")."""
    A = np.asarray(A, float)
    cols = np.abs(A).max(axis=0, initial=0.0)
    cols = np.where(cols > 0, cols, 1.0)
    A = A / cols
    rows = np.abs(A).max(axis=1, initial=0.0)
    return A / np.where(rows > 0, rows, 1.0)[:, None], cols
