"""CasADi functions called from Python without the per-call conversions.

``f(q, u)`` from Python wraps every argument in a ``DM`` and every result must be turned back
into NumPy (``np.asarray(DM)``): 50-250 us a call on this machine, for functions that evaluate in
about 1 us. :class:`Buffered` evaluates through CasADi's ``Function.buffer()`` instead: the
arguments are copied into NumPy arrays that CasADi reads in place, the results are written into
NumPy arrays (1-4 us a call). The hot loops of a simulation (a projection's Gauss-Newton steps,
the samples' multipliers, the integrator itself) call their functions this way. :func:`evaluate`
does the same once for a wide (mapped) function on whole arrays: inverse dynamics over all frames.
"""
from __future__ import annotations

import threading

import casadi as ca
import numpy as np

from ..errors import ModelError


class Buffered:
    """``f`` callable with NumPy arguments, returning dense NumPy results (one array per output,
    of the output's shape; a column vector as a 1-D array). Results are fresh arrays. Thread-safe
    (the one buffer is locked during a call)."""

    def __init__(self, f: ca.Function):
        self.function = f
        self._args = [np.zeros(f.nnz_in(i)) for i in range(f.n_in())]
        self._zeros = [np.zeros(f.sparsity_in(i).numel()) for i in range(f.n_in())]
        self._dense_in = [f.sparsity_in(i).is_dense() for i in range(f.n_in())]
        self._in_index = [_dense_index(f.sparsity_in(i)) for i in range(f.n_in())]
        self._res = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        self._out = [(f.sparsity_out(i).shape, _dense_index(f.sparsity_out(i))) for i in range(f.n_out())]
        self._lock = threading.Lock()
        self._buffer, self._eval = f.buffer()   # the buffer holds pointers into the arrays above: keep both
        for i, a in enumerate(self._args):
            self._buffer.set_arg(i, memoryview(a))
        for i, r in enumerate(self._res):
            self._buffer.set_res(i, memoryview(r))

    def __reduce__(self):
        # Pickled as its function alone: the buffer's pointers and the lock are this process's. A problem goes to Dask
        # workers pickled with its equations' caches (multistart), and a Buffered kept there after a first solve in
        # maximal coordinates (the guess's projection) made solve(starts=N, client=...) fail: "cannot pickle
        # '_thread.lock' object" (tests/test_multistart.py).
        return Buffered, (self.function,)

    def __call__(self, *args) -> list[np.ndarray]:
        with self._lock:   # one buffer: calls from several threads take turns
            for i, a in enumerate(args):
                flat = np.asarray(a, dtype=float).ravel(order="F")   # CasADi's column-major storage
                self._args[i][:] = flat if self._dense_in[i] else flat[self._in_index[i]]
            self._eval()
            out = []
            for (shape, index), r in zip(self._out, self._res):
                if index is None:
                    dense = r.copy()
                else:
                    dense = np.zeros(shape[0] * shape[1])
                    dense[index] = r
                out.append(dense if shape[1] == 1 else dense.reshape(shape[1], shape[0]).T)
            return out


    def named(self, **kwargs) -> dict[str, np.ndarray]:
        """Arguments by name (those left out are zero), results by name."""
        f = self.function
        args = [kwargs.get(name, zero) for name, zero in zip(f.name_in(), self._zeros)]
        return dict(zip(f.name_out(), self(*args)))


def _dense_index(sp: ca.Sparsity) -> np.ndarray | None:
    """Positions (column-major) of the nonzeros in the dense matrix; None when dense."""
    if sp.is_dense():
        return None
    rows, cols = sp.get_triplet()
    return np.asarray(cols, dtype=int) * sp.size1() + np.asarray(rows, dtype=int)


__all__ = ["Buffered"]


def evaluate(F: ca.Function, *args) -> list[np.ndarray]:
    """``F(*args)`` for dense NumPy inputs (each of ``F.size_in(i)``) as dense NumPy outputs.

    Through :meth:`casadi.Function.buffer`: CasADi reads and writes the arrays' memory, so a
    mapped evaluation over thousands of samples costs no Python list per entry (which
    ``np.asarray(DM)`` builds, and which costs more than the evaluation itself).
    """
    buf, run = F.buffer()
    keep = []
    for i, a in enumerate(args):
        a = np.asarray(a, float)
        if a.shape != F.size_in(i):
            raise ModelError(f"{F.name()}: input {i} ('{F.name_in(i)}') has shape {a.shape}, expected {F.size_in(i)}")
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
        if sp.is_dense():
            out.append(nz.reshape(sp.shape, order="F"))
            continue
        dense = np.zeros(sp.shape)
        rows, cols = sp.get_triplet()
        dense[np.asarray(rows, int), np.asarray(cols, int)] = nz
        out.append(dense)
    return out
