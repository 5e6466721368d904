"""Mesh points whose times are NLP variables: the horizon cut into phases of unknown length (issue 19).

A Radau mesh normally fixes each interval's length as a fraction ``h`` of the horizon ``T``. With
``Radau(..., free_points=(i, ...))`` the inner mesh points ``i`` cut the horizon into phases, and phase ``k``
has its own time scale ``b_k`` (seconds per unit of the mesh's nominal fraction ``s``): an interval of nominal
length ``h`` in phase ``k`` lasts ``h b_k`` seconds, its quadrature weights are scaled alike, and one row ties
the phases to the horizon,

    sum_k (s_{k+1} - s_k) b_k = T        (the final time, fixed or a variable),

so a free point's time ``t_i = sum_{k < phase(i)} (s_{k+1} - s_k) b_k`` is the optimizer's choice. This is how
GPOPS-II places an input's switch (Patterson and Rao 2014: phases whose boundary times are variables): a jump
that no effort term holds (a bang-bang or bang-off-bang input) is exact only at a mesh point, and where that
point's time is fixed the NLP trades its error against barrier-sized values at almost no cost.

Each phase's map from ``s`` to time is affine, so a solution's collocation polynomials are those of the mesh
whose points sit at the solved times: :func:`solved_view` returns the transcription seen on that mesh, which the
solution carries, and its interpolation, error estimates and warm starts see an ordinary mesh.

Only Radau (its weight at an interval's start is zero, so every point's quadrature weight comes from one interval,
hence one phase), only the direct transcriptions (maximal or joint coordinates), and only problems whose point
functions do not read the time itself (the elements evaluate ``t = s T``, which a phase's scale does not give).
A free point belongs where something on either side of it is held (an input at its bounds, :mod:`.jump_arcs`): on a
smooth solution the objective hardly depends on the mesh and the NLP optimizes its own discretization error (the
swing-up on Radau 5 x 10 with two free points: 1,844 IPOPT iterations, the points moved 0.15 of the horizon).
"""
from __future__ import annotations

import copy
from dataclasses import replace

import casadi as ca
import numpy as np

from ..errors import ModelError
from .schemes import Radau

# A phase's time scale kept within these multiples of the horizon's bounds: each phase stays of positive length
# (free points keep their order) and a junction moves at most within its neighbours' reach.
SCALE_RANGE = (0.2, 5.0)


def phase_of_intervals(scheme) -> np.ndarray:
    """Each interval's phase (0 .. number of free points)."""
    return np.searchsorted(np.asarray(scheme.free_points, int), np.arange(scheme.intervals), side="right")


def phase_of_points(tr) -> np.ndarray:
    """Each collocation point's phase: that of the interval it belongs to or ends (Radau: a mesh point is the last
    collocation point of the interval it ends; ``t_0``, of weight zero, is in the first phase)."""
    phases = phase_of_intervals(tr.scheme)
    out = np.zeros(tr.layout.n_points, int)
    for k in range(tr.scheme.intervals):
        out[tr.offsets[k] + 1 : tr.offsets[k + 1] + 1] = phases[k]
    return out


def phase_lengths(scheme) -> np.ndarray:
    """Each phase's nominal length, a fraction of the horizon."""
    mesh = scheme.mesh_fractions
    edges = np.concatenate([[0.0], mesh[list(scheme.free_points)], [1.0]])
    return np.diff(edges)


def check_free_points(tr, point: dict) -> None:
    """Refuse free points where the NLP cannot hold them (module notes): a :class:`ModelError` naming why."""
    if not tr.scheme.free_points:
        return
    name = getattr(tr, "user_problem", tr.problem).model.name
    for key in ("kinematics", "residuals", "integrand", "path"):
        f = point.get(key)
        if f is None:
            continue
        args = [ca.SX.sym(f"in{j}", f.sparsity_in(j)) for j in range(f.n_in())]
        if ca.depends_on(ca.vertcat(*[ca.vec(o) for o in f.call(args)]), args[-1]):
            raise ModelError(f"free_points: model '{name}' reads the time itself in its {key}; a phase of unknown "
                             f"length gives each point its duration, not its time; solve without free_points")


def scale_bounds(tr) -> tuple[float, float]:
    """Bounds of every phase's time scale (s per unit fraction, :data:`SCALE_RANGE`)."""
    pr = getattr(tr, "user_problem", tr.problem)
    if pr.t_final_bounds is not None:
        lo, hi = (float(b) for b in pr.t_final_bounds)
        lo = lo if lo > 0.0 else 1e-3 * hi
    else:
        lo = hi = float(pr.t_final)
    return SCALE_RANGE[0] * lo, SCALE_RANGE[1] * hi


def link_row(s, n: int, free_time: bool):
    """``(z, c, rows, cost)`` of the row that ties the phases' scales to the horizon (module notes)."""
    b, lengths = ca.SX.sym("b", n), ca.SX.sym("lengths", n)
    T = s.T
    z = ca.vertcat(b, T) if free_time else b
    c = lengths if free_time else ca.vertcat(lengths, T)
    return z, c, ca.dot(lengths, b) - T, 0


def solved_mesh(scheme, scales: np.ndarray) -> np.ndarray:
    """The mesh's points at the solved times, fractions of the solved horizon."""
    mesh, phases = scheme.mesh_fractions, phase_of_intervals(scheme)
    seconds = np.concatenate([[0.0], np.cumsum(np.diff(mesh) * np.asarray(scales, float)[phases])])
    return seconds / seconds[-1]


def solved_view(tr, w: np.ndarray):
    """``tr`` seen on the mesh of its solved free points (module notes); ``tr`` itself where it has none."""
    n = tr.layout.n_phases
    if not n:
        return tr
    start = int(np.sum(tr.layout.sizes()[:6]))
    mesh = solved_mesh(tr.scheme, np.asarray(w, float)[start : start + n])
    view = copy.copy(tr)
    view.scheme = replace(tr.scheme, mesh=tuple(float(m) for m in mesh))
    view.fractions, view.quadrature = view.point_times(view.scheme)
    # Arcs imposed (.imposed_arcs), in fractions of the horizon: their ends move with the mesh.
    nominal = tr.scheme.mesh_fractions
    view.arcs = tuple(replace(a, start=float(np.interp(a.start, nominal, mesh)), end=float(np.interp(a.end, nominal, mesh)))
                      for a in tr.arcs)
    return view


def freed_at(scheme, times: list[float]):
    """``scheme`` with a mesh point at each of ``times`` (fractions, :func:`with_junction_points`), those points free."""
    placed = with_junction_points(scheme, times)
    mesh = placed.mesh_fractions
    points = sorted({int(np.argmin(np.abs(mesh - at))) for at in times})
    return replace(placed, free_points=tuple(points))


def with_junction_points(scheme: Radau, times: list[float]) -> Radau:
    """``scheme`` with a mesh point at each junction (fractions of the horizon): the nearest mesh point moved there where it lies within a
    quarter of its shorter interval (not the ends, nor a point an earlier junction was put on: two junctions closer
    than a mesh interval, a short free arc between two arcs, each get their own point), else the interval holding it
    split there (both pieces at its degree)."""
    mesh = list(scheme.mesh_fractions)
    degrees = list(np.asarray(scheme.degrees if scheme.degrees is not None else [scheme.degree] * scheme.intervals))
    placed: set = set()
    for at in sorted(times):
        k = int(np.argmin(np.abs(np.asarray(mesh) - at)))
        if mesh[k] == at:
            placed.add(at)
            continue
        shorter = min(mesh[k] - mesh[k - 1] if k > 0 else np.inf, mesh[k + 1] - mesh[k] if k + 1 < len(mesh) else np.inf)
        if 0 < k < len(mesh) - 1 and abs(mesh[k] - at) <= 0.25 * shorter and mesh[k] not in placed:
            mesh[k] = at
        else:
            j = int(np.searchsorted(mesh, at)) - 1
            mesh.insert(j + 1, at)
            degrees.insert(j, degrees[j])
        placed.add(at)
    return Radau(mesh=tuple(float(m) for m in mesh), degrees=tuple(int(d) for d in degrees))
