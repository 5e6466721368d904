"""The loads.csv columns of DESIGN.md's results contract, from samples of ``(t, q, u, lambda)``.

The one place that names and evaluates the joint-load columns, for every result type and
every writer of ``loads.csv``:

- per scalar constraint ``<constraint>.lambda`` (the multiplier: N, N m, or the unit of
  its constraint);
- per load channel (a joint; a two-body joint once per body as ``<joint>@<body>``):
  ``.F_x .F_y .F_z`` (N), ``.M_x .M_y .M_z`` (N m), ``.point_x .point_y .point_z`` (m,
  where ``F`` acts), ``.power`` (W), all in the fixed basis: Lagrange's prescription
  ``F_c = lambda f_C`` at ``X_C``, ``M_c = lambda h_C`` (paper eq. 26) and its power
  ``F_c . v_C + M_c . omega`` (eq. 27).

Evaluation is vectorised: the channel function of :class:`SystemEquations` is
``Function.map``-ped over all samples in one call.
"""
from __future__ import annotations

import difflib

import numpy as np

from ..errors import ModelError, UnknownColumnError
from .bodies import Point
from .equations import SystemEquations

QUANTITIES = ("F", "M", "point")
_PER_CHANNEL = 10          # F (3), M (3), point (3), power: the layout of SystemEquations.loads_function


def channel_column_names(prefix: str) -> list[str]:
    """``<prefix>.F_x`` ... ``<prefix>.point_z``, ``<prefix>.power`` in loads.csv order."""
    return [f"{prefix}.{k}_{a}" for k in QUANTITIES for a in "xyz"] + [f"{prefix}.power"]


def load_column_names(eqs: SystemEquations) -> list[str]:
    """The names of the columns :func:`load_columns` returns, in order (``t`` not included)."""
    names = [f"{n}.lambda" for n in eqs.constraint_names]
    for ch in eqs.load_channels:
        names += channel_column_names(ch.prefix)
    return names


def _samples(eqs: SystemEquations, t, q, u, lam) -> tuple[np.ndarray, ...]:
    """Samples as arrays (samples x size), checked against the model's sizes."""
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    n = len(t)
    out = [t]
    for what, a, size in (("q", q, eqs.nq), ("u", u, eqs.nu), ("lambda", lam, eqs.nc)):
        a = np.asarray(a, dtype=float)
        if a.ndim < 2 and a.size == n * size:           # one sample given as a vector, or no columns
            a = a.reshape(n, size)
        if a.shape != (n, size):
            raise ModelError(f"model '{eqs.model.name}': {what} must have shape ({n}, {size}) for {n} sample(s), "
                             f"got {np.shape(a)}")
        out.append(a)
    return tuple(out)


class LoadColumns(dict):
    """The columns by name; a name that is not one raises :class:`UnknownColumnError` (a ``KeyError``)
    naming the closest columns: a two-body joint's loads are ``<joint>@<body>.F_x``, not ``<joint>.F_x``,
    and a bare ``KeyError: 'hinge.F_x'`` does not say so."""

    def __missing__(self, name):
        names = list(self)
        joint = str(name).split("@")[0].split(".")[0]
        quantity = str(name).rsplit(".", 1)[-1]
        close = [n for n in names if n.startswith(f"{joint}@") and n.endswith(f".{quantity}")]
        close += [n for n in difflib.get_close_matches(str(name), names, n=5, cutoff=0.7) if n not in close]
        channels = sorted({n.rsplit(".", 1)[0] for n in names if not n.endswith(".lambda")})
        hint = f"; did you mean {', '.join(repr(c) for c in close[:5])}?" if close else ""
        raise UnknownColumnError(f"no load column named {name!r}{hint} Columns are '<constraint>.lambda' and, per "
                                 f"joint load, '<load>.F_x' ... '.power' for the loads {channels} (a two-body "
                                 f"joint once per body, '<joint>@<body>')")


def load_columns(eqs: SystemEquations, t, q, u, lam) -> dict[str, np.ndarray]:
    """DESIGN.md's loads.csv columns at every sample (rows of ``q``, ``u``, ``lam``; ``t`` in s).

    Per scalar constraint ``<name>.lambda``; per load channel ``F`` (N) at ``point`` (m),
    ``M`` (N m) and ``power`` (W) in the fixed basis (paper eqs. 26-27). One mapped
    CasADi evaluation over all samples.
    """
    t, q, u, lam = _samples(eqs, t, q, u, lam)
    cols = LoadColumns({f"{name}.lambda": lam[:, k] for k, name in enumerate(eqs.constraint_names)})
    channels = eqs.load_channels
    if not channels:
        return cols
    n = len(t)
    if n:
        values = np.asarray(eqs.loads_function.map(n)(q.T, u.T, t[None, :], lam.T)).reshape(-1, n)
    else:
        values = np.zeros((_PER_CHANNEL * len(channels), 0))
    for c, ch in enumerate(channels):
        block = values[_PER_CHANNEL * c : _PER_CHANNEL * (c + 1)]
        for name, row in zip(channel_column_names(ch.prefix), block):
            cols[name] = row
    return cols


def load_about(eqs: SystemEquations, joint: str, point: Point, t, q, u, lam) -> tuple[np.ndarray, np.ndarray]:
    """The load of ``joint`` moved to the material point ``point`` at every sample (eq. 33).

    ``joint`` is a load channel (a joint name, or ``<joint>@<body>`` for a two-body
    joint); ``point`` a model :class:`Point`. Returns ``(F, M_A)``, each samples x 3, in
    the fixed basis (N, N m): ``F`` unchanged, ``M_A = M_C + (x_C - x_A) x F``.
    """
    names = [ch.prefix for ch in eqs.load_channels]
    if joint not in names:
        raise ModelError(f"no joint load '{joint}'; joint loads: {names}")
    if not isinstance(point, Point):
        raise ModelError(f"load_about('{joint}', ...): the point must be a model Point (body.point(...) or "
                         f"body.com), got {type(point).__name__}")
    if eqs.model.bodies.get(point.body.name) is not point.body:
        raise ModelError(f"load_about('{joint}', ...): point '{point.name}' is on a body '{point.body.name}' that is "
                         f"not in model '{eqs.model.name}' (a point of another model object?); take the point from "
                         "this result's model")
    t, q, u, lam = _samples(eqs, t, q, u, lam)
    n = len(t)
    if not n:
        return np.zeros((0, 3)), np.zeros((0, 3))
    F, M = eqs.load_about_function(joint, point).map(n)(q.T, u.T, t[None, :], lam.T)
    return np.asarray(F).T.copy(), np.asarray(M).T.copy()
