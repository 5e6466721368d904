"""Coordinates filtered and differentiated as OpenSim's InverseDynamicsTool does (step 2 of
:mod:`ocp_constraints.biomech.gait`): pad by odd reflection, 3rd-order Butterworth forward and
backward (zero phase) at 6 Hz, then interpolating quintic splines, differentiated twice.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GaitError
from .opensim_files import Table

FILTER_TEXT = ("Butterworth low-pass, 3rd order, run forward and backward (zero phase; OpenSim's "
               "Signal::LowpassIIR), after padding each column by odd reflection over half its length")


def check_cutoff(cutoff: float | None, motion: Table) -> float | None:
    """The low-pass cutoff (Hz) if it is usable: finite and strictly between 0 and the Nyquist
    frequency ``1 / (2 dt)`` of the motion (``dt`` its mean sample period, :func:`sample_period`). ``None``
    means no filter (asked for explicitly). Anything else is a :class:`GaitError` that says what to use."""
    if cutoff is None:
        return None
    dt = sample_period(motion.time)
    nyquist = 0.5 / dt
    fc = float(cutoff)
    if not np.isfinite(fc) or fc <= 0.0:
        raise GaitError(f"cutoff {cutoff!r} Hz is not a positive frequency: give 0 < cutoff < {nyquist:.4g} Hz "
                        "(the Nyquist frequency of the motion), or --no-filter to use the coordinates unfiltered")
    if fc >= nyquist:
        raise GaitError(f"cutoff {fc:g} Hz is at or above the Nyquist frequency {nyquist:.4g} Hz of the motion "
                        f"{motion.path} (sampled at {1.0 / dt:.4g} Hz): a low-pass filter cannot act there; "
                        f"give a cutoff below {nyquist:.4g} Hz (OpenSim's default is 6 Hz), or --no-filter")
    return fc


def sample_period(t: np.ndarray) -> float:
    """The mean sample period (s), from the span: ``(t_end - t_start) / (n - 1)``. Not the median step:
    time stamps written to 4 decimals make a 120 Hz record's steps 0.0083 and 0.0084 s, whose median
    (120.48 Hz) put the Nyquist frequency above the true 60 Hz and let a cutoff of 60.2 Hz through."""
    return float((t[-1] - t[0]) / (len(t) - 1))


def motion_units(motion: Table) -> dict:
    """How the motion's angles were read (header, extension or range; see :func:`read_motion`)."""
    keys = ("angles_converted_from_degrees", "in_degrees_source", "angle_unit_note")
    return {k: motion.metadata[k] for k in keys if k in motion.metadata}


# -- 2. coordinates: OpenSim's filter and spline ------------------------------------------------

def _opensim_iir(y: np.ndarray, dt: float, fc: float) -> np.ndarray:
    """OpenSim ``Signal::LowpassIIR``: 3rd-order Butterworth, forward then backward (zero phase).

    ``y``: samples along the first axis; columns are filtered together (one loop over time,
    not one per column: the same arithmetic, 59 times fewer Python steps for JW).

    Each pass starts in the filter's steady state for its first sample (as if the signal had
    been constant before it: SciPy's ``filtfilt`` with ``lfilter_zi``), not with OpenSim's
    output set to the first three inputs. That start is not a state of the filter, and the
    transient it sets off decays like the largest pole's radius to the power of the samples:
    within the padding at 6 Hz (radius 0.74 on 60 Hz data), but not near the Nyquist frequency
    (radius 0.995 at 29.9 Hz), where it moved gait2354's hip flexion by 1.29 rad where the
    filter, nearly a pass-through there, should move it by 3e-5 (``tests/test_gait_signals.py``)."""
    if not 0.0 < fc < 0.5 / dt:        # check_cutoff refuses these before; never clamp silently
        raise GaitError(f"cutoff {fc:g} Hz is not below the Nyquist frequency {0.5 / dt:.4g} Hz of the resampled motion")
    wa = np.tan(2 * np.pi * fc * dt / 2.0)
    wa2, wa3 = wa * wa, wa ** 3
    den = (wa + 1) * (wa2 + wa + 1.0)
    a = np.array([wa3, 3 * wa3, 3 * wa3, wa3]) / den
    b = np.array([1.0, (3 * wa3 + 2 * wa2 - 2 * wa - 3) / den, (3 * wa3 - 2 * wa2 - 2 * wa + 3) / den,
                  (wa - 1) * (wa2 - wa + 1) / den])

    def once(x):
        # three samples of the first value ahead: the steady state of a filter whose gain at 0 Hz is 1
        x = np.concatenate([np.repeat(np.asarray(x[:1], dtype=float), 3, axis=0), np.asarray(x, dtype=float)])
        out = x.copy()
        for i in range(3, len(x)):
            out[i] = (a[0] * x[i] + a[1] * x[i - 1] + a[2] * x[i - 2] + a[3] * x[i - 3]
                      - b[1] * out[i - 1] - b[2] * out[i - 2] - b[3] * out[i - 3])
        return out[3:]

    return once(once(y)[::-1])[::-1]


def _pad(x: np.ndarray, n: int) -> np.ndarray:
    """OpenSim ``Signal::Pad``: reflect and negate about both end values."""
    head = 2 * x[0] - x[n:0:-1]
    tail = 2 * x[-1] - x[-2:-n - 2:-1]
    return np.concatenate([head, x, tail])


# -- interpolating quintic splines (SciPy's make_interp_spline(k=5), without importing SciPy's
# interpolate package: 0.5 s of CPU, a quarter of a whole `gait` command) -----------------------

def _spans(t: np.ndarray, k: int, n: int, x: np.ndarray) -> np.ndarray:
    """Knot span ``i`` of each ``x`` (``t[i] <= x < t[i+1]``), ``k <= i < n``; outside: the end spans."""
    return np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)


def _basis(t: np.ndarray, k: int, i: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The ``k + 1`` B-splines of degree ``k`` nonzero on span ``i``, at ``x`` (Cox-de Boor; points x (k+1))."""
    N = np.zeros((len(x), k + 1))
    N[:, 0] = 1.0
    left, right = np.zeros((len(x), k + 1)), np.zeros((len(x), k + 1))
    for j in range(1, k + 1):
        left[:, j] = x - t[i + 1 - j]
        right[:, j] = t[i + j] - x
        saved = np.zeros(len(x))
        for r in range(j):
            temp = N[:, r] / (right[:, r + 1] + left[:, j - r])
            N[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        N[:, j] = saved
    return N


def _banded_solve(B: np.ndarray, y: np.ndarray, k: int) -> np.ndarray:
    """``B^-1 y`` for a collocation matrix with at most ``k`` nonzeros below and above the diagonal.

    Gaussian elimination without pivoting inside the band: B-spline collocation matrices are
    totally positive, for which that is stable (de Boor, A Practical Guide to Splines, XIII).
    O(n k^2) without BLAS (a dense solve of JW's 590 x 590 system costs 0.05-0.2 s and
    contends for the cores when BLAS runs threads)."""
    B, y = B.copy(), np.array(y, float)
    n = len(B)
    for j in range(n - 1):
        r1, c1 = min(n, j + k + 1), min(n, j + k + 1)
        f = B[j + 1:r1, j] / B[j, j]
        B[j + 1:r1, j:c1] -= np.outer(f, B[j, j:c1])
        y[j + 1:r1] -= np.multiply.outer(f, y[j])
    x = np.empty_like(y)
    for j in range(n - 1, -1, -1):
        c1 = min(n, j + k + 1)
        x[j] = (y[j] - np.tensordot(B[j, j + 1:c1], x[j + 1:c1], axes=1)) / B[j, j]
    return x


@dataclass
class QuinticSpline:
    """Interpolating B-spline of degree 5 with not-a-knot ends (de Boor XIII(12)), as SciPy's
    ``make_interp_spline(x, y, k=5)``: knots ``x[0]`` (6 times), ``x[3:-3]``, ``x[-1]`` (6 times).
    Columns of ``y`` are separate curves. ``spline(x, nu)``: the ``nu``-th derivative at ``x``."""

    t: np.ndarray
    c: np.ndarray
    k: int = 5

    @classmethod
    def interpolate(cls, x, y) -> "QuinticSpline":
        x, y = np.asarray(x, float), np.asarray(y, float)
        k, n = 5, len(x)
        if n < k + 1:
            raise GaitError(f"a quintic spline needs at least {k + 1} samples, got {n}")
        t = np.r_[(x[0],) * (k + 1), x[3:-3], (x[-1],) * (k + 1)]
        i = _spans(t, k, n, x)
        B = np.zeros((n, n))        # collocation matrix (banded: k + 1 entries a row)
        rows = np.arange(n)[:, None]
        B[rows, i[:, None] - k + np.arange(k + 1)] = _basis(t, k, i, x)
        return cls(t, _banded_solve(B, y, k), k)

    def __call__(self, x, nu: int = 0) -> np.ndarray:
        t, c, k = self.t, self.c, self.k
        for _ in range(nu):          # derivative of a B-spline: degree k - 1 on t[1:-1]
            c = k * (c[1:] - c[:-1]) / (t[k + 1:-1] - t[1:-k - 1]).reshape((-1,) + (1,) * (c.ndim - 1))
            t, k = t[1:-1], k - 1
        x = np.atleast_1d(np.asarray(x, float))
        i = _spans(t, k, len(c), x)
        N = _basis(t, k, i, x)
        idx = i[:, None] - k + np.arange(k + 1)
        return np.einsum("pr,pr...->p...", N, c[idx])


@dataclass
class CoordinateSplines:
    """Filtered coordinates as quintic splines: values, rates and accelerations at any time."""

    names: list[str]
    splines: object
    t_range: tuple[float, float]
    settings: dict = None

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, float))
        return tuple(np.asarray(self.splines(t, k)) for k in range(3))


def filter_coordinates(table: Table, names: list[str], cutoff: float | None = 6.0) -> CoordinateSplines:
    """Coordinates of ``table`` low-passed and splined as OpenSim's InverseDynamicsTool does.

    Pad each column by half its length (odd reflection), resample at the smallest step
    if the sampling is not uniform, 3rd-order Butterworth forward and backward at
    ``cutoff`` Hz (None: no filter), then interpolating quintic splines.
    """
    t = table.time
    Y = np.column_stack([table.column(n) for n in names])
    dt_m = sample_period(t)
    settings = {"coordinates": {"applied": cutoff is not None, "cutoff_hz": cutoff,
                                "motion_sampling_hz": 1.0 / dt_m, "nyquist_hz": 0.5 / dt_m,
                                "filter": FILTER_TEXT if cutoff is not None else "none (--no-filter)",
                                "resampled_step_s": None,
                                "splines": "interpolating quintic splines through the (filtered) samples, "
                                           "differentiated twice for speeds and accelerations"},
                "ground_reactions": "not filtered: linear interpolation at the motion's sample times"}
    if cutoff is not None:
        n = len(t) // 2
        tp = _pad(t, n)
        Yp = np.column_stack([_pad(Y[:, k], n) for k in range(Y.shape[1])])
        dt = float(np.min(np.diff(tp)))
        if (tp[-1] - tp[0]) / (len(tp) - 1) - dt > np.finfo(float).eps:
            tn = tp[0] + dt * np.arange(int(np.floor((tp[-1] - tp[0]) / dt + 1e-9)) + 1)
            Yp = QuinticSpline.interpolate(tp, Yp)(tn)
            tp = tn
            settings["coordinates"]["resampled_step_s"] = dt
        Yf = _opensim_iir(Yp, dt, cutoff)
        t, Y = tp, Yf
    return CoordinateSplines(names, QuinticSpline.interpolate(t, Y), (table.time[0], table.time[-1]), settings)


