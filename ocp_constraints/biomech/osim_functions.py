"""OpenSim's coordinate functions (Constant, LinearFunction, SimmSpline, NaturalCubicSpline,
MultiplierFunction) as functions evaluable on CasADi SX/MX/DM, and their parser.

SimmSpline is the Forsythe-Malcolm-Moler cubic spline (third derivatives at the ends from
divided differences, *not* natural end conditions), extrapolated linearly, as in OpenSim.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import OsimModelError


class OsimFunction:
    """A scalar function of one coordinate, evaluable on CasADi SX/MX/DM."""

    def __call__(self, x):  # pragma: no cover - interface
        raise NotImplementedError

    @property
    def is_constant(self) -> bool:
        return False

    def affine(self) -> tuple[float, float] | None:
        """``(slope, offset)`` if the function is ``slope * x + offset``, else None."""
        return None


@dataclass
class Constant(OsimFunction):
    value: float

    def __call__(self, x=None):
        return ca.DM(self.value) if x is None else 0 * x + self.value

    @property
    def is_constant(self) -> bool:
        return True

    def affine(self):
        return (0.0, self.value)


@dataclass
class LinearFunction(OsimFunction):
    slope: float
    offset: float

    def __call__(self, x):
        return self.slope * x + self.offset

    def affine(self):
        return (self.slope, self.offset)


@dataclass
class Multiplier(OsimFunction):
    scale: float
    inner: OsimFunction

    def __call__(self, x=None):
        return self.scale * self.inner(x)

    @property
    def is_constant(self) -> bool:
        return self.inner.is_constant

    def affine(self):
        a = self.inner.affine()
        return None if a is None else (self.scale * a[0], self.scale * a[1])


@dataclass
class CubicSpline(OsimFunction):
    """Piecewise cubic ``y_k + d (b_k + d (c_k + d e_k))``, ``d = x - x_k``; linear outside."""

    x: np.ndarray
    y: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray

    def __call__(self, x):
        X, Y, n = self.x, self.y, len(self.x)
        expr = Y[-1] + (x - X[-1]) * self.b[-1]
        for k in range(n - 2, -1, -1):
            dx = x - X[k]
            expr = ca.if_else(x <= X[k + 1], Y[k] + dx * (self.b[k] + dx * (self.c[k] + dx * self.d[k])), expr)
        return ca.if_else(x < X[0], Y[0] + (x - X[0]) * self.b[0], expr)


def simm_spline(x, y) -> CubicSpline:
    """OpenSim's SimmSpline (Forsythe, Malcolm & Moler end conditions), as in SimmSpline.cpp."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    n = len(x)
    if n < 2 or len(y) != n or np.any(np.diff(x) <= 0):
        raise OsimModelError(f"SimmSpline needs >= 2 points with increasing x, got x={x.tolist()}")
    b, c, d = np.zeros(n), np.zeros(n), np.zeros(n)
    if n == 2:
        b[:] = (y[1] - y[0]) / (x[1] - x[0])
        return CubicSpline(x, y, b, c, d)
    nm1, nm2 = n - 1, n - 2
    d[0] = x[1] - x[0]
    c[1] = (y[1] - y[0]) / d[0]
    for i in range(1, nm1):
        d[i] = x[i + 1] - x[i]
        b[i] = 2.0 * (d[i - 1] + d[i])
        c[i + 1] = (y[i + 1] - y[i]) / d[i]
        c[i] = c[i + 1] - c[i]
    b[0], b[nm1], c[0], c[nm1] = -d[0], -d[nm2], 0.0, 0.0
    if n > 3:
        c[0] = c[2] / (x[3] - x[1]) - c[1] / (x[2] - x[0])
        c[nm1] = c[nm2] / (x[nm1] - x[n - 3]) - c[n - 3] / (x[nm2] - x[n - 4])
        c[0] = c[0] * d[0] * d[0] / (x[3] - x[0])
        c[nm1] = -c[nm1] * d[nm2] * d[nm2] / (x[nm1] - x[n - 4])
    for i in range(1, n):
        t = d[i - 1] / b[i - 1]
        b[i] -= t * d[i - 1]
        c[i] -= t * c[i - 1]
    c[nm1] /= b[nm1]
    for j in range(nm1):
        i = nm2 - j
        c[i] = (c[i] - d[i] * c[i + 1]) / b[i]
    b[nm1] = (y[nm1] - y[nm2]) / d[nm2] + d[nm2] * (c[nm2] + 2.0 * c[nm1])
    for i in range(nm1):
        b[i] = (y[i + 1] - y[i]) / d[i] - d[i] * (c[i + 1] + 2.0 * c[i])
        d[i] = (c[i + 1] - c[i]) / d[i]
        c[i] *= 3.0
    c[nm1] *= 3.0
    d[nm1] = d[nm2]
    return CubicSpline(x, y, b, c, d)


def natural_spline(x, y) -> CubicSpline:
    """Natural cubic spline (zero second derivative at both ends) through the points."""
    from scipy.interpolate import CubicSpline as SciSpline

    x, y = np.asarray(x, float), np.asarray(y, float)
    s = SciSpline(x, y, bc_type="natural")
    c3, c2, c1 = s.c[0], s.c[1], s.c[2]
    slope_end = float(s(x[-1], 1))
    return CubicSpline(x, y, np.append(c1, slope_end), np.append(c2, 0.0), np.append(c3, 0.0))


def _floats(text: str | None, where: str) -> np.ndarray:
    try:
        return np.array([float(v) for v in (text or "").split()])
    except ValueError:
        raise OsimModelError(f"{where}: '{text}' is not a list of numbers") from None


def parse_function(elem: ET.Element, where: str) -> OsimFunction:
    """An OpenSim Function element (``Constant``, ``LinearFunction``, ``SimmSpline``...)."""
    tag = elem.tag
    if tag == "Constant":
        return Constant(float(_floats(elem.findtext("value"), where)[0]))
    if tag == "LinearFunction":
        a = _floats(elem.findtext("coefficients"), where)
        return LinearFunction(float(a[0]), float(a[1]))
    if tag in ("SimmSpline", "NaturalCubicSpline"):
        x, y = _floats(elem.findtext("x"), where), _floats(elem.findtext("y"), where)
        return simm_spline(x, y) if tag == "SimmSpline" else natural_spline(x, y)
    if tag == "MultiplierFunction":
        inner = elem.find("function")
        if inner is None or len(inner) == 0:
            raise OsimModelError(f"{where}: MultiplierFunction without a function")
        return Multiplier(float(_floats(elem.findtext("scale"), where)[0]), parse_function(inner[0], where))
    raise OsimModelError(f"{where}: coordinate function '{tag}' is not supported "
                         "(Constant, LinearFunction, SimmSpline, NaturalCubicSpline, MultiplierFunction are)")
