"""Collocation schemes: how one mesh interval is discretized.

A scheme is a small strategy object. Each interval ``[t_k, t_k + h]`` carries states
``X_j`` and state derivatives ``D_j`` at local points ``tau_j`` (``tau_0 = 0``,
``tau_last = 1``; the last point of an interval is the first of the next). The
implicit dynamics are imposed at every point; the scheme supplies the *defects* that
tie ``X`` and ``D`` together and the quadrature weights of integral costs:

- :class:`Trapezoidal`: ``X_1 - X_0 = h/2 (D_0 + D_1)`` (second order);
- :class:`HermiteSimpson` (separated form): ``X_m = (X_0 + X_1)/2 + h/8 (D_0 - D_1)``,
  ``X_1 - X_0 = h/6 (D_0 + 4 D_m + D_1)`` (fourth order);
- :class:`Radau`: Legendre-Gauss-Radau collocation of degree ``d``,
  ``h D_j = sum_r C_rj X_r`` at the ``d`` Radau points (order ``2d - 1`` at the mesh
  points); ``degrees=(d_0, d_1, ...)`` gives each interval its own degree (hp meshes,
  :mod:`ocp_constraints.ocp.mesh_refinement`).

Every scheme answers :meth:`Scheme.interval_scheme` (the scheme of one interval: itself,
or a uniform Radau of that interval's degree) and :attr:`Scheme.points_per_interval`, so
the transcription needs no case for non-uniform meshes or degrees.
"""
from __future__ import annotations

import functools
from dataclasses import KW_ONLY, dataclass, field

import casadi as ca
import numpy as np

from ..errors import ModelError


def _lagrange_derivative_matrix(tau: np.ndarray) -> np.ndarray:
    """``C[r, j] = l_r'(tau_j)`` for the Lagrange basis ``l_r`` through ``tau``.

    Barycentric form (Berrut and Trefethen 2004): ``l_r'(tau_j) = (w_r / w_j) / (tau_j - tau_r)`` for
    ``j != r`` with ``w_r = 1 / prod_{s != r} (tau_r - tau_s)``, and ``l_j'(tau_j) = -sum_{r != j} l_r'(tau_j)``
    (the basis sums to one). Products of numpy.poly1d took ~40 ms per degree-9 matrix.
    """
    tau = np.asarray(tau, dtype=float)
    diff = tau[:, None] - tau[None, :]
    np.fill_diagonal(diff, 1.0)
    w = 1.0 / diff.prod(axis=1)
    D = (w[None, :] / w[:, None]) / diff          # D[j, r] = l_r'(tau_j), j != r
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D.T.copy()


@functools.lru_cache(maxsize=64)
def _cached_derivative_matrix(tau: tuple) -> np.ndarray:
    C = _lagrange_derivative_matrix(np.asarray(tau))
    C.setflags(write=False)
    return C


def _quadrature_weights(points: np.ndarray) -> np.ndarray:
    """``int_0^1 l_j(tau) dtau`` for the Lagrange basis through ``points``."""
    w = np.zeros(len(points))
    for j in range(len(points)):
        p = np.poly1d([1.0])
        for s in range(len(points)):
            if s != j:
                p *= np.poly1d([1.0, -points[s]]) / (points[j] - points[s])
        P = np.polyint(p)
        w[j] = P(1.0) - P(0.0)
    return w


@dataclass(frozen=True)
class Scheme:
    """Base class: a uniform mesh of ``intervals`` or a user-given ``mesh`` on ``[0, 1]``."""

    intervals: int = 50
    # Everything after the interval count is named: ``Radau(20, 6)`` could mean 20 intervals of
    # degree 6 or the reverse, so it is refused by Python instead of misread.
    _: KW_ONLY
    mesh: tuple[float, ...] | None = None
    # Inner mesh points (indices 1 .. intervals - 1) whose times are NLP variables: the horizon is cut there into
    # phases of unknown length (Radau only; :mod:`.free_mesh_points`). Meant for jumps held on both sides (a refinement
    # puts a bang-bang input's there itself); on a smooth solution the NLP would tune its own discretization error.
    free_points: tuple[int, ...] = ()
    tau: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.mesh is not None:
            m = np.asarray(self.mesh, dtype=float)
            if m.ndim != 1 or len(m) < 2 or m[0] != 0.0 or m[-1] != 1.0 or np.any(np.diff(m) <= 0):
                raise ModelError("mesh must be increasing fractions of the horizon from 0.0 to 1.0")
            object.__setattr__(self, "intervals", len(m) - 1)
        elif not (isinstance(self.intervals, int) and self.intervals >= 1):
            raise ModelError(f"intervals must be a positive whole number, got {self.intervals!r}")
        points = tuple(self.free_points)
        if points and (type(self).__name__ != "Radau" or not all(isinstance(i, (int, np.integer)) for i in points)
                       or list(points) != sorted(set(points)) or points[0] < 1 or points[-1] > self.intervals - 1):
            raise ModelError(f"free_points must be increasing indices of inner mesh points (1 to {self.intervals - 1}) of "
                             f"a Radau mesh, got {self.free_points!r} on {type(self).__name__}")
        object.__setattr__(self, "free_points", tuple(int(i) for i in points))

    @property
    def mesh_fractions(self) -> np.ndarray:
        if self.mesh is not None:
            return np.asarray(self.mesh, dtype=float)
        return np.linspace(0.0, 1.0, self.intervals + 1)

    @property
    def label(self) -> str:
        return type(self).__name__.lower()

    def defects(self, X: list, D: list, h) -> list:
        raise NotImplementedError

    @property
    def weights(self) -> np.ndarray:
        """Quadrature weights over the local points (sum 1; multiply by ``h``)."""
        raise NotImplementedError

    @property
    def first_point_has_controls(self) -> bool:
        """False where the scheme never uses controls at ``t_0`` (Radau): they are tied to the next point."""
        return True

    @property
    def derivative_matrix(self) -> np.ndarray | None:
        """``C`` with ``h x'(tau_j) = sum_r C[r, j] x_r`` at the points after ``tau_0``, where the
        scheme defines derivatives from states alone (Radau); else None."""
        return None

    @property
    def accelerations_from_speeds(self) -> np.ndarray | None:
        """``C`` where the NLP should take ``u'`` from the speeds instead of variables, else None."""
        return None

    @property
    def order(self) -> int:
        raise NotImplementedError

    def interval_scheme(self, k: int) -> "Scheme":
        """The scheme of interval ``k`` (its ``tau``, defects, weights): the same on every interval here."""
        return self

    @property
    def points_per_interval(self) -> np.ndarray:
        """Points of each interval, both ends included (the last shared with the next interval)."""
        return np.full(self.intervals, len(self.tau), dtype=int)

    @property
    def point_count(self) -> int:
        """Collocation points over the whole mesh (unique times)."""
        return int(np.sum(self.points_per_interval - 1) + 1)


@dataclass(frozen=True)
class Trapezoidal(Scheme):
    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "tau", np.array([0.0, 1.0]))

    def defects(self, X, D, h):
        return [X[1] - X[0] - h / 2 * (D[0] + D[1])]

    @property
    def weights(self):
        return np.array([0.5, 0.5])

    @property
    def order(self) -> int:
        return 2


@dataclass(frozen=True)
class HermiteSimpson(Scheme):
    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "tau", np.array([0.0, 0.5, 1.0]))

    @property
    def label(self) -> str:
        return "hermite-simpson"

    def defects(self, X, D, h):
        return [
            X[1] - (X[0] + X[2]) / 2 - h / 8 * (D[0] - D[2]),
            X[2] - X[0] - h / 6 * (D[0] + 4 * D[1] + D[2]),
        ]

    @property
    def weights(self):
        return np.array([1.0, 4.0, 1.0]) / 6

    @property
    def order(self) -> int:
        return 4


@dataclass(frozen=True)
class Radau(Scheme):
    """Legendre-Gauss-Radau collocation of ``degree`` on every interval, or of ``degrees[k]`` on interval ``k``."""

    _: KW_ONLY
    degree: int = 3
    degrees: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.degrees is not None:
            degrees = tuple(self.degrees)
            if len(degrees) != self.intervals or not all(isinstance(d, (int, np.integer)) and 1 <= d <= 9 for d in degrees):
                raise ModelError(f"Radau degrees must be one whole number from 1 to 9 per interval ({self.intervals} "
                                 f"intervals), got {self.degrees!r}")
            degrees = tuple(int(d) for d in degrees)
            # One degree everywhere is the uniform scheme: the same label, NLP and cache key.
            object.__setattr__(self, "degrees", None if len(set(degrees)) == 1 else degrees)
            object.__setattr__(self, "degree", degrees[0] if len(set(degrees)) == 1 else max(degrees))
        if not (isinstance(self.degree, int) and 1 <= self.degree <= 9):
            raise ModelError(f"Radau degree must be a whole number from 1 to 9, got {self.degree!r}")
        object.__setattr__(self, "tau", np.array([0.0, *ca.collocation_points(self.degree, "radau")]))

    @property
    def label(self) -> str:
        if self.degrees is not None:
            return f"radau{min(self.degrees)}-{max(self.degrees)}"
        return f"radau{self.degree}"

    def interval_scheme(self, k: int) -> "Scheme":
        return self if self.degrees is None else _uniform_radau(self.degrees[k])

    @property
    def points_per_interval(self) -> np.ndarray:
        if self.degrees is None:
            return super().points_per_interval
        return np.asarray(self.degrees, dtype=int) + 1

    def defects(self, X, D, h):
        # One matrix product for all the points (4x faster to build than a sum of numpy scalars times SX
        # vectors, term by term: 1.4 against 6.0 ms per interval kind at degree 9, 12 states; the same
        # expressions, instruction for instruction).
        XC = ca.horzcat(*X) @ ca.DM(self.derivative_matrix)
        return [h * D[j] - XC[:, j] for j in range(1, len(X))]

    @property
    def derivative_matrix(self) -> np.ndarray:
        # Cached per set of points (read-only): the transcription asks once per interval, and
        # building it with numpy.poly1d cost 2.4 s of CPU per solve at N = 200.
        return _cached_derivative_matrix(tuple(self.tau))

    @property
    def accelerations_from_speeds(self) -> np.ndarray | None:
        if self.degrees is not None:
            # Mixed degrees: the transcription takes each interval's own matrix; this says only
            # whether every interval gives u' from its speeds (else every point has variables).
            return self.derivative_matrix if max(self.degrees) <= 4 else None
        # Up to degree 4 fewer variables make IPOPT's factorization cheaper; from degree 6
        # on, the denser Hessian blocks (each point's dynamics reads all the interval's
        # speeds) cost more than they save: per iteration on the swing-up, N = 20, degree 3
        # -12 %, degree 5 -4 % (but +15 % at N = 80), degree 9 +48 %
        # (python scripts/radau_acceleration_variables.py).
        return self.derivative_matrix if self.degree <= 4 else None

    @property
    def weights(self):
        # Radau quadrature over the d collocation points (exact to degree 2d - 2).
        return _radau_tables(self.degree)[0]

    @property
    def first_point_has_controls(self) -> bool:
        return False

    @property
    def start_extrapolation(self) -> np.ndarray:
        """``l_j(0)`` for the Lagrange basis through the collocation points: inputs at ``t_0``
        are the first interval's input polynomial extrapolated there."""
        return _radau_tables(self.degree)[1]

    @property
    def order(self) -> int:
        return 2 * self.degree - 1


@functools.lru_cache(maxsize=None)
def _radau_tables(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature weights and ``l_j(0)`` of Radau ``degree``, computed once: an hp mesh asks for
    them once per interval (numpy.poly1d algebra, ~20 ms each)."""
    pts = np.asarray(ca.collocation_points(degree, "radau"), float)
    extrapolation = np.array([np.prod([(0.0 - pts[s]) / (pts[j] - pts[s]) for s in range(len(pts)) if s != j])
                              for j in range(len(pts))])
    weights = np.concatenate([[0.0], _quadrature_weights(pts)])
    for a in (weights, extrapolation):
        a.setflags(write=False)
    return weights, extrapolation


@functools.lru_cache(maxsize=None)
def _uniform_radau(degree: int) -> Radau:
    """The one-interval Radau scheme of ``degree`` (its tau, matrices and weights), shared."""
    return Radau(1, degree=degree)


def scheme_from_name(name: str, intervals: int = 50, degree: int = 3, mesh=None) -> Scheme:
    """``"trapezoidal"``, ``"hermite-simpson"`` or ``"radau"`` (with ``degree``)."""
    mesh = None if mesh is None else tuple(float(m) for m in mesh)
    if name == "trapezoidal":
        return Trapezoidal(intervals, mesh=mesh)
    if name in ("hermite-simpson", "hermite_simpson"):
        return HermiteSimpson(intervals, mesh=mesh)
    if name == "radau":
        return Radau(intervals, mesh=mesh, degree=degree)
    raise ModelError(f"unknown transcription '{name}': use trapezoidal, hermite-simpson or radau")
