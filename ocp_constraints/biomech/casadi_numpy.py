"""Evaluate a CasADi function on NumPy arrays into NumPy arrays, without Python lists.

``np.asarray(F(X))`` converts each output through ``DM.elements()``, a Python list of every
entry: for the mapped kinematics and constraint Jacobians of a gait trial (millions of
entries) that conversion costs more than the evaluation. :func:`evaluate` instead hands
CasADi the arrays' memory (``Function.buffer``) and scatters the outputs' nonzeros.
"""
from __future__ import annotations

import casadi as ca
import numpy as np


def evaluate(F: ca.Function, *args) -> list[np.ndarray]:
    """``F(*args)`` for dense NumPy inputs (each of ``F.size_in(i)``), as dense NumPy outputs."""
    buf, run = F.buffer()
    keep = []
    for i, a in enumerate(args):
        a = np.asarray(a, float)
        if a.shape != F.size_in(i):
            raise ValueError(f"{F.name()}: input {i} has shape {a.shape}, expected {F.size_in(i)}")
        column_major = np.ascontiguousarray(a.T)
        keep.append(column_major)
        buf.set_arg(i, memoryview(column_major))
    nonzeros = []
    for i in range(F.n_out()):
        nz = np.zeros(F.sparsity_out(i).nnz())
        keep.append(nz)
        buf.set_res(i, memoryview(nz))
        nonzeros.append(nz)
    run()
    out = []
    for i, nz in enumerate(nonzeros):
        sp = F.sparsity_out(i)
        dense = np.zeros(sp.shape)
        rows, cols = sp.get_triplet()
        dense[np.asarray(rows, int), np.asarray(cols, int)] = nz
        out.append(dense)
    return out
