"""An input held on its bound over an arc, imposed on the NLP (issue 19; :mod:`.junction_times` finds the arcs' ends).

An input with an effort term (a torque limit on a motor whose ``tau^2`` is minimized) that reaches its bound rides it
over an arc and leaves it continuously, with a kink, at each *junction*. With the bound as an inequality, two things
keep the NLP's input about 1e-5 of the bound from the optimum, however fine the mesh (the torque-limited rod of
``examples/torque_limited_rod.py``; ``python scripts/junction_at_mesh_point.py``):

- a junction inside a mesh interval, a kink that no polynomial follows;
- IPOPT's barrier on the arc next to a junction: it holds the input ``mu / z`` off the bound, and the bound's
  multiplier ``z`` falls to zero at the junction (with mesh points at the exact junctions, the rod's torque there was
  1.2e-5 of the bound short of it, whatever the tolerance asked of the mesh).

So the arc is imposed (:func:`pin_arcs`): the input fixed at its bound at the arc's points, its bound dropped over
the free interval next to each junction. The junction must then be a mesh point, and its time is the root of the
input's continuity mismatch there (:func:`mismatch`): the free side's polynomial at the junction less the bound
(:mod:`.junction_times`). On the rod at 1e-6 the junctions end 7.6e-12 s from the closed form's and the torque
2.5e-11 of its bound from it, on 51 points (``python scripts/junction_at_mesh_point.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .schemes import Radau
from .switch_detection import activity, detect_switches, penalized_inputs


@dataclass(frozen=True)
class Arc:
    """``input`` held at ``value`` (one of its bounds) from ``start`` to ``end`` (s); a start at 0 or an end at the
    final time is no junction (the arc runs from the start or to the end)."""

    input: str
    value: float
    start: float
    end: float


def _times(tr) -> tuple[np.ndarray, np.ndarray, float]:
    T = float(getattr(tr, "user_problem", tr.problem).t_final)
    return tr.fractions * T, tr.scheme.mesh_fractions * T, T


def _input_columns(tr, name: str) -> np.ndarray:
    """The decision-vector index of input ``name`` at every point."""
    lay = tr.layout
    first = int(np.sum(lay.sizes()[:3]))         # the blocks x, a, lam come before the inputs (.layout)
    r = list(getattr(tr, "user_problem", tr.problem).model.inputs).index(name)
    return first + np.arange(lay.n_points) * lay.n_in + r


def inner_junctions(arcs: list[Arc], T: float) -> list[tuple[int, str, float]]:
    """``(arc, "start" | "end", time)`` of every inner junction."""
    eps = 1e-9 * T
    return [(k, side, at) for k, a in enumerate(arcs) for side, at in (("start", a.start), ("end", a.end))
            if eps < at < T - eps]


def _free_interval(t: np.ndarray, mesh: np.ndarray, at: float, side: str, T: float) -> np.ndarray:
    """The points of the free interval next to a junction at mesh point ``at``: before an arc's start (up to ``at``,
    which Radau's interval ends on), after an arc's end (``at`` not included)."""
    eps = 1e-9 * T
    k = int(np.argmin(np.abs(mesh - at)))
    if side == "start":
        return (t > mesh[max(k - 1, 0)] + eps) & (t <= at + eps)
    return (t > at + eps) & (t <= mesh[min(k + 1, len(mesh) - 1)] + eps)


def pinned(tr, arcs: list[Arc]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The decision-vector indices each arc fixes (its points after its start: at an inner start the point is the
    free interval's last, whose value is the mismatch; ``t = 0`` left to Radau's extrapolation), and those whose bound
    each inner junction drops (the free interval next to it; each junction a mesh point)."""
    t, mesh, T = _times(tr)
    eps = 1e-9 * T
    fixed = [_input_columns(tr, a.input)[(t > max(a.start, 0.0) + eps) & (t <= a.end + eps)] for a in arcs]
    freed = [_input_columns(tr, arcs[k].input)[_free_interval(t, mesh, at, side, T)] for k, side, at in inner_junctions(arcs, T)]
    return fixed, freed


def pin_arcs(tr, arcs: list[Arc], lbx: np.ndarray, ubx: np.ndarray) -> None:
    """Impose ``arcs`` on a transcription's variable bounds, in place (:func:`pinned`)."""
    fixed, freed = pinned(tr, arcs)
    for a, cols in zip(arcs, fixed):
        lbx[cols] = ubx[cols] = a.value
    for cols in freed:
        lbx[cols], ubx[cols] = -np.inf, np.inf


def mismatch(solution, arcs: list[Arc], scale: dict[str, float]) -> np.ndarray:
    """Per inner junction (:func:`inner_junctions`' order): the free side's input at the junction less the arc's value,
    over the input's ``scale``: before a start, the free interval's last point (at the junction); after an end, the
    polynomial through the free interval's points, evaluated at the junction."""
    tr = solution.transcription
    t, mesh, T = _times(tr)
    out = []
    for k, side, at in inner_junctions(arcs, T):
        a = arcs[k]
        u = np.asarray(solution.sample(a.input), float).ravel()
        free = _free_interval(t, mesh, at, side, T)
        if side == "start":
            value = u[np.flatnonzero(free)[-1]]
        else:
            ts, us = t[free] - at, u[free]
            value = float(np.polyval(np.polyfit(ts, us, len(ts) - 1), 0.0))
        out.append((value - a.value) / scale[a.input])
    return np.asarray(out, float)


def find_arcs(solution) -> tuple[list[Arc], dict[str, float]]:
    """The arcs on which each bounded input with an effort term (:func:`.switch_detection.penalized_inputs`: it leaves
    its bound continuously) sits at a bound, at two points or more, their ends at the located junctions
    (:func:`.switch_detection.detect_switches`); and each such input's scale (its bounds' largest magnitude)."""
    tr = solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    t, _, T = _times(tr)
    smooth, located, arcs, scale = None, None, [], {}
    for name, (lo, hi) in pr.bounds.items():
        if name not in pr.model.inputs:
            continue
        v = np.asarray(solution.sample(name), float).ravel()
        s, _ = activity(v, lo, hi)
        s[0] = 0                                    # t = 0: Radau's extrapolated input
        if not s.any():
            continue
        if smooth is None:      # only where an input reaches a bound (the curvature at every point: ~1 ms)
            smooth = penalized_inputs(solution)
            located = [w for w in detect_switches(solution) if w.kind == "junction" and w.source == "input"]
        if name not in smooth:
            continue
        runs = np.flatnonzero(np.diff(np.concatenate([[0], (s != 0).astype(int), [0]])))
        for i, j in zip(runs[::2], runs[1::2] - 1):
            if j == i or s[i] != s[j] or np.any(s[i : j + 1] != s[i]):
                continue
            start = 0.0 if i <= 1 else _nearest([w.fraction * T for w in located if w.quantity == name], t[i - 1], t[i])
            end = T if j == len(t) - 1 else _nearest([w.fraction * T for w in located if w.quantity == name], t[j], t[j + 1])
            arcs.append(Arc(name, float(lo if s[i] < 0 else hi), start, end))
            scale[name] = max(abs(b) for b in (lo, hi) if np.isfinite(b))
    return arcs, scale


def _nearest(located: list[float], a: float, b: float) -> float:
    """The located junction between points ``a`` and ``b`` (or nearest to them), else their midpoint."""
    inside = [x for x in located if a - (b - a) <= x <= b + (b - a)]
    return min(inside, key=lambda x: abs(x - 0.5 * (a + b))) if inside else 0.5 * (a + b)


def with_junction_points(scheme: Radau, times: list[float], T: float) -> Radau:
    """``scheme`` with a mesh point at each junction time: the nearest mesh point moved there where it lies within a
    quarter of its shorter interval (not the ends), else the interval holding it split there (both pieces at its
    degree)."""
    mesh = list(scheme.mesh_fractions)
    degrees = list(np.asarray(scheme.degrees if scheme.degrees is not None else [scheme.degree] * scheme.intervals))
    for at in sorted(x / T for x in times):
        k = int(np.argmin(np.abs(np.asarray(mesh) - at)))
        shorter = min(mesh[k] - mesh[k - 1] if k > 0 else np.inf, mesh[k + 1] - mesh[k] if k + 1 < len(mesh) else np.inf)
        if 0 < k < len(mesh) - 1 and abs(mesh[k] - at) <= 0.25 * shorter:
            mesh[k] = at
        else:
            j = int(np.searchsorted(mesh, at)) - 1
            mesh.insert(j + 1, at)
            degrees.insert(j, degrees[j])
    return Radau(mesh=tuple(float(m) for m in mesh), degrees=tuple(int(d) for d in degrees))
