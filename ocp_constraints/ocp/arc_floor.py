"""The error an interior point leaves on a state bound's arc, which a companion shares and cannot see.

Where a coordinate or speed is held at its bound over an arc (or a path constraint of the coordinates, speeds and
time alone, ``subject_to``), the exact solution lies *on* the bound there, and a coordinate held at a constant bound
does not move (a path constraint of the coordinates and time: its rate is zero). IPOPT's interior point holds a bound ``mu / z`` inside it, ``z``
the bound's multiplier, and where the bound carries little (``z`` small: Bryson and Denham's block on its wall, the
push zero along the arc) that gap is not negligible and varies along the arc. The companion, solved the same way,
has the same gap: their difference, the estimate, does not see it. On Bryson-Denham at 1e-6 the block's speed along
the wall reached 8.7e-8 at the points (exactly 0 there), 1.40x the estimate (6.2e-8), and its largest true error
(``python scripts/bryson_denham_refinement.py``).

So on every mesh interval that lies wholly on a located arc (its entry and exit located as junctions by
:mod:`.switch_detection`, or the horizon's ends), the states' error is at least, at each point,

- ``|x - bound|``, the bounded state's distance from its bound, and
- for a bounded coordinate ``q_i``, ``|q_i'| / ||N_i||_1`` with ``q' = N(q) u`` (the bodies' kinematics, :attr:`.SystemEquations.rate_matrix`): its rate is exactly zero
  on the arc, and ``|q_i'| <= ||N_i||_1 max_j |u_j - u_j*|`` bounds the speeds' error from below.

These are errors of the solution itself at its points, not estimates: :func:`arc_floor` gives their largest per
interval and per bounded quantity, and the states' estimate (:func:`.error_estimate.estimate_error`) is at least
:data:`.error_estimate.SAFETY` times that, as it is that many times the difference it sees elsewhere. No mesh lowers
it (a shorter interval makes ``z``, which carries the points' quadrature weights, smaller, and the gap larger): the
refinement does not refine for it, and where only it keeps the estimate above the tolerance the refinement stops,
"met" false, and says so (:meth:`.error_estimate.ErrorEstimate.held_by_arcs`, ``arc_note``). Bryson-Denham at 1e-7:
"met" before with its true error 1.51x the estimate (7.7e-8 against 5.1e-8); now "not met" after one refinement
(2.2 s of CPU), true/estimate 0.50 (with the floor in the per-interval shares too, a first version refined 10 times,
21.7 s, and ended "not met" all the same). Intervals holding a junction, and the points before and after an arc, are
left out: there the exact solution leaves the bound, and its distance and rate are not errors.
"""
from __future__ import annotations

from functools import cache

import casadi as ca
import numpy as np

from .switch_detection import ACTIVE, TIGHT, activity


def arc_floor(solution, switches) -> tuple[np.ndarray, dict[str, float]]:
    """Per mesh interval of ``solution``, the largest error its states are known to have on a located arc of a state
    bound or a path constraint of the states (module notes; zero where there is none), and per quantity with such an
    arc, its largest. ``switches``: the solution's located switches (:func:`.switch_detection.detect_switches`)."""
    tr = solution.transcription
    mesh, frac = tr.scheme.mesh_fractions, tr.fractions
    floor, held = np.zeros(tr.scheme.intervals), {}
    for name, g, lo, hi, errors in _held_quantities(solution):
        s, eps = activity(g, lo, hi)
        junctions = np.array(sorted(w.fraction for w in switches if w.quantity == name and w.kind == "junction"))
        for a, b in _runs(s):
            # The run of points near the bound takes in the approach (within ACTIVE of the scale); the arc lies
            # between the first and the last junction located over it, or the horizon's ends.
            over = junctions[(junctions >= frac[max(a - 1, 0)]) & (junctions <= frac[min(b + 1, len(g) - 1)])]
            t_in = 0.0 if a == 0 else (float(over[0]) if over.size else None)
            t_out = 1.0 if b == len(g) - 1 else (float(over[-1]) if over.size else None)
            if t_in is None or t_out is None or t_out <= t_in:
                continue                  # an arc whose entry or exit is not located: where it lies is not known
            bound = lo if s[a] < 0 else hi
            for k in np.flatnonzero((mesh[:-1] >= t_in) & (mesh[1:] <= t_out)):
                points = np.asarray(tr.interval_points(int(k)))
                if np.abs(g[points] - bound).max() > eps * TIGHT / ACTIVE:
                    continue      # not held tightly: the two junctions may bound a dip off the bound, not an arc
                error = float(errors(points, bound).max())
                floor[k] = max(floor[k], error)
                held[name] = max(held.get(name, 0.0), error)
    return floor, held


def _held_quantities(solution) -> list:
    """``(name, values at the points, lower, upper, errors)`` of every bound on a coordinate or speed and every path
    constraint of the coordinates, speeds and time alone; ``errors(points, bound)``: the states' error each point
    is known to have if the exact solution lies on ``bound`` there (module notes). A path constraint ``g`` the same
    through its gradient: ``|g - bound| / ||dg/dx||_1``, and where ``g`` holds no speed, its rate
    ``g' = dg/dq q' + dg/dt`` (zero on the arc) over ``||dg/dq N||_1`` (Bryson-Denham's wall written as a path
    constraint, ``subject_to(x, upper=1/9)``: at 1e-6 the true error was 1.72x the estimate without it)."""
    tr = solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    e, traj, t = pr.eqs, solution.trajectory, solution.t
    coordinates, speeds = pr.model.coordinate_names, pr.model.speed_names
    bounded = [(n, float(lo), float(hi)) for n, (lo, hi) in pr.bounds.items() if n in coordinates or n in speeds]
    paths = [c for c in pr.path_constraints if not ca.depends_on(c.expression, ca.vertcat(e.inputs, pr.lam))]
    if not bounded and not paths:
        return []
    P = len(t)
    q, u = np.asarray(traj.q, float).T, np.asarray(traj.u, float).T

    @cache
    def kinematics() -> tuple[np.ndarray, np.ndarray]:
        """q' and N(q) at every point (nq x P, nq x P x nu): evaluated only where an arc is found."""
        return (np.asarray(e.coordinate_rates.map(P)(q, u), float),
                np.asarray(e.rate_matrix.map(P)(q), float).reshape(e.nq, P, e.nu))

    def coordinate(g: np.ndarray, i: int):
        def errors(points, bound):
            rates, N = kinematics()
            return _errors(g[points] - bound, 1.0, rates[i, points], np.abs(N[i, points]).sum(axis=1))   # ||N_i||_1
        return errors

    def speed(g: np.ndarray):
        return lambda points, bound: _errors(g[points] - bound, 1.0)

    def path(g: np.ndarray, dg: np.ndarray, dt: np.ndarray, holds_speeds: bool):
        def errors(points, bound):
            gradient = np.abs(dg[:, points]).sum(axis=0)                             # ||dg/dx||_1
            if holds_speeds:
                return _errors(g[points] - bound, gradient)
            rates, N = kinematics()
            dq = dg[: e.nq, points]
            rate = np.einsum("ip,ip->p", dq, rates[:, points]) + dt[points]         # g' = dg/dq q' + dg/dt
            through = np.abs(np.einsum("ip,ipj->pj", dq, N[:, points])).sum(axis=1)  # ||dg/dq N||_1
            return _errors(g[points] - bound, gradient, rate, through)
        return errors

    out = []
    for name, lo, hi in bounded:
        g = np.asarray(solution.sample(name), float)
        out.append((name, g, lo, hi, coordinate(g, coordinates.index(name)) if name in coordinates else speed(g)))
    for c in paths:
        g, dg, dt = (np.asarray(v, float) for v in _path_function(pr, c).map(P)(q, u, t[None, :]))
        dg = dg.reshape(P, e.nq + e.nu).T                                             # dg/dx, nx x P
        out.append((c.label, g.ravel(), float(c.lower), float(c.upper),
                    path(g.ravel(), dg, dt.ravel(), ca.depends_on(c.expression, e.u))))
    return out


def _path_function(pr, constraint) -> ca.Function:
    """``(q, u, t) -> (g, dg/dx, dg/dt)`` of a path constraint's expression, built once per expression and kept on the
    problem (each refinement estimates twice; an edited constraint is another expression, so another entry)."""
    store = pr.__dict__.setdefault("_held_functions", {})
    kept = store.get(id(constraint.expression))
    if kept is None or kept[0] is not constraint.expression:     # the expression is kept too: its id is not reused
        e, g = pr.eqs, constraint.expression
        kept = store[id(g)] = (g, ca.Function("held", [e.q, e.u, e.t],
                                              [g, ca.jacobian(g, ca.vertcat(e.q, e.u)), ca.jacobian(g, e.t)]))
    return kept[1]


def _errors(gap: np.ndarray, scale, rate=None, through=None) -> np.ndarray:
    """``|gap| / scale``, and with a ``rate`` (zero on the arc) at least ``|rate| / through``."""
    out = np.abs(gap) / np.maximum(scale, 1e-300)
    return out if rate is None else np.maximum(out, np.abs(rate) / np.maximum(through, 1e-300))


def _runs(s: np.ndarray) -> list[tuple[int, int]]:
    """``(first, last)`` point of every run of points held at one bound (``s`` -1 or +1 throughout)."""
    out, start = [], None
    for i, value in enumerate(s):
        if start is not None and value != s[start]:
            out.append((start, i - 1))
            start = None
        if start is None and value != 0:
            start = i
    if start is not None:
        out.append((start, len(s) - 1))
    return out
