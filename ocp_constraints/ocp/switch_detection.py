"""Where a solution switches inside a mesh interval, read from the NLP's own bounds (issue 19).

A bound or path constraint that changes between active and inactive makes the solution non-smooth
there: a bang-bang input jumps from one bound to the other (minimum-time swing-up), a multiplier
riding a load bound (the four-bar's pin force, a friction cone) has a kink where the bound becomes
active or inactive. Inside an interval, one polynomial cannot follow a jump or a kink: a higher degree
resolves it no better, the companion of :mod:`.error_estimate` is no upper bound there, and halving
the interval again and again only narrows it down geometrically. At a mesh point, each side is a smooth
arc and the estimate holds again. So the switch is *located* and the interval split there (the idea of
Liu, Hager and Rao 2015 and of the bang-bang structure detection of Agamawi, Hager and Rao 2020, who
read it from the switching function; here from the primal values, which every transcription has).
Jumps split (:func:`split_points`); junctions are located and reported but split only with
:data:`SPLIT_JUNCTIONS`, off: measured, it cost more than it gained.

For every bounded quantity (an input or state with :meth:`bound`, a path constraint of
:meth:`subject_to`) the value at each point of an interval (its collocation points, and the mesh point
at its start, which for inputs and multipliers is the previous interval's last collocation point) is
*active* at its lower or upper bound, within :data:`ACTIVE` of the quantity's scale, or *free*. Where
the activity changes between two neighbouring points the switch is located between them:

- from one bound to the other (bang-bang), where the piecewise-linear interpolation of the points
  crosses the middle of the two bounds (an intermediate point value is the NLP's partial step: a value
  ``u_m`` at a point stands for the bound held over the matching part of its neighbourhood);
- between a bound and a free arc (a junction, where the multipliers kink), where the free points reach
  the bound: the straight line through the two nearest, drawn for their distance from the bound (a
  mixed constraint's slack grows linearly away from its junction), for its square root (a speed
  limit, or a load that follows the speeds, leaves its bound tangentially) or for its cube root (a
  position bound reached with zero speed and acceleration, Bryson and Denham's wall), whichever the third
  nearest lies on most closely (:func:`.switch_location._junction`), anywhere back along the run of points counted active
  (within the activity threshold a tangential approach looks active early: a continuous quantity's line is
  drawn through the approach's points there too, :func:`.switch_location._approach`).

A switch in the first half of the gap between an interval's start and its first collocation point is *at
the mesh point* (Radau's inputs there are the interval before's: a jump exactly at it shows as a clean
change). Any other switch lies *inside* its interval.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from .interpolation import imposed_jumps
from .switch_location import JUMP_SPAN, locate  # noqa: F401 (JUMP_SPAN: its callers read it here)

# A value within this fraction of the quantity's scale (the larger of its finite bounds' magnitudes and
# its span over the horizon) of a bound is active. IPOPT's interior point leaves a bound by mu / lambda,
# larger where the multiplier is small near a switch (the minimum-time swing-up's torque: 4.996 at a
# bound of 5 next to the switch, 4e-4 of its span of 10); a free value half-way (0.28) is far from it.
ACTIVE = 2e-3
# Within this fraction of the scale a bound is held tightly; between TIGHT and ACTIVE loosely (_loose).
TIGHT = 1e-5
# Fraction of the horizon below which an interval is not split at a junction (split_points).
JUNCTION_MIN = 1e-3
# Whether junctions (kinks) split intervals too. Measured, they do not pay yet: the walker at 1e-4 took 14 solves to
# 617 points, 136 s CPU (11 to 323, 69 s without), the rolling-disk drive at 1e-4 ended in IPOPT's Restoration_Failed
# on 51 intervals, the four-bar was at 3.2e-4 / 1.4e-3 after 3 refinements, 145 s CPU; jumps do pay (split_points).
SPLIT_JUNCTIONS = False
# A junction closer than this fraction of its interval to one of the interval's ends is at that mesh point.
JUNCTION_NEAR = 0.05
# Switches of several quantities closer than this fraction of their interval are one switch.
MERGE = 0.02


@dataclass(frozen=True)
class Switch:
    """A change of a bounded quantity between active and inactive (or between its bounds).

    ``fraction``: the located switch in normalized time ``[0, 1]``; ``interval``: the mesh interval it
    lies in; ``inside``: False where it sits at the interval's start (the mesh point); ``quantity``: the
    bound's or path constraint's name; ``source``: ``"input"`` or ``"state"`` (a bound on one) or ``"path"``
    (a path constraint); ``kind``: ``"bang-bang"`` or ``"junction"``; ``bracket``: the
    two points around it whose activity differs (fractions); ``effect``: how far the speeds (m/s, rad/s;
    the NLP's) are from those of a clean switch at ``fraction``, over the bracket (:func:`_effect`): the
    NLP smears a jump over the points of its bracket (their bounds held loosely), and a jump that is no
    mesh point sits at the nearest one. ``imposed``: a junction of an arc imposed on the NLP (:mod:`.imposed_arcs`), at
    its mesh point by construction."""

    fraction: float
    interval: int
    inside: bool
    quantity: str
    kind: str
    bracket: tuple[float, float] = (0.0, 0.0)
    effect: float = 0.0
    source: str = "path"
    imposed: bool = False


def bounded_quantities(solution) -> list[tuple[str, np.ndarray, float, float, bool, bool]]:
    """``(name, values at every point, lower, upper, states only, continuous)`` of every bound on an input,
    coordinate or speed and of every path constraint of the user's problem (a joint-coordinate NLP's too).
    *Continuous*: a coordinate or speed, or a path constraint of the coordinates, speeds and time alone (a
    joint's speed limit), which cannot jump: only inputs and multipliers can (:func:`locate`)."""
    tr = solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    state_names = set(pr.model.coordinate_names + pr.model.speed_names)
    out = [(name, np.asarray(solution.sample(name), float), float(lo), float(hi), name in state_names,
            name in state_names) for name, (lo, hi) in pr.bounds.items()]
    if pr.path_constraints:
        e, traj, t = pr.eqs, solution.trajectory, solution.t
        f = ca.Function("path", [e.q, e.u, e.inputs, pr.lam, e.t],
                        [ca.vertcat(*[c.expression for c in pr.path_constraints])]).map(len(t))
        g = np.asarray(f(np.asarray(traj.q).T, np.asarray(traj.u).T, np.asarray(traj.inputs).T,
                         np.asarray(traj.lam).T, t[None, :])).reshape(len(pr.path_constraints), len(t))
        jumping = ca.vertcat(e.inputs, pr.lam)
        out += [(c.label, row, float(c.lower), float(c.upper), False,
                 not (jumping.numel() and ca.depends_on(c.expression, jumping)))
                for c, row in zip(pr.path_constraints, g)]
    return out


def activity(values: np.ndarray, lower: float, upper: float) -> tuple[np.ndarray, float]:
    """Per point: -1 at the lower bound, +1 at the upper bound, 0 free (within :data:`ACTIVE` of the
    scale); and that threshold."""
    finite = [abs(b) for b in (lower, upper) if np.isfinite(b)]
    span = float(values.max() - values.min()) if values.size else 0.0
    eps = ACTIVE * max([span, *finite, 1e-12])
    return np.where(values <= lower + eps, -1, np.where(values >= upper - eps, 1, 0)), eps


def _loose(v: np.ndarray, s: np.ndarray, i: int, step: int, tight: float, lower: float, upper: float) -> int:
    """From the active point ``i``, the farthest point in direction ``step`` up to which the values stay
    active at the same bound but further from it than ``tight``: IPOPT's interior point holds a bound
    loosely where its multiplier is small, next to a switch (the switching function vanishes there), and
    the inputs and multipliers there are neither the jump's nor the arc's (minimum-time swing-up: a
    torque of 4.991-4.998 at a bound of 5 over ten intervals next to the switch, multipliers 1e-3 off)."""
    bound = lower if s[i] < 0 else upper
    while 0 <= i + step < len(v) and s[i + step] == s[i] and abs(v[i + step] - bound) > tight:
        i += step
    return i


def _effect(t: np.ndarray, D: np.ndarray, U: np.ndarray, at: float, mesh: np.ndarray, T: float) -> float:
    """How far the speeds ``U`` (m/s, rad/s; the NLP's) stray from a clean switch at ``at`` (s) across a bracket:
    the largest ``|u - u_clean|`` at its points, ``u_clean`` from the first point's speeds on with the accelerations
    ``D`` of the bracket's ends before and after ``at`` (the NLP's own speeds: trapezoids of its accelerations across
    a gap that holds the jump made an error of about the jump times half the gap); and, if ``at`` is no mesh point,
    the jump of the accelerations times its distance from the nearest one (where a clean jump at that mesh point
    would put it)."""
    clean = U[:, :1] + D[:, :1] * (np.minimum(t, at) - t[0])[None, :] + D[:, -1:] * (np.maximum(t, at) - at)[None, :]
    misplaced = float(np.abs(D[:, -1] - D[:, 0]).max()) * float(np.abs(mesh * T - at).min())
    return max(float(np.abs(U - clean).max()), misplaced)


def _effective(ends: np.ndarray, D: np.ndarray, U: np.ndarray, at: float) -> float:
    """Where the NLP's own states put a jump between the bracket's ends (s): the time of a clean switch between the
    accelerations ``D`` at the two ends that changes the speed jumping most by as much as the NLP's speeds ``U`` do. The
    crossing of the bounds' middle (``at``, kept if the ends do not decide) reads a value at a mesh point (8.77 between
    bounds of 10 and -5) as half a step: on the asymmetric bang-bang block at 1e-4 it put the switch 3.3e-6 of the
    horizon past the mesh point the NLP switches at, and that distance times the jump floored the states' estimate at
    3.8e-5 for a true error of 2.2e-7."""
    row = int(np.argmax(np.abs(D[:, 1] - D[:, 0])))
    jump = D[row, 0] - D[row, 1]
    if jump == 0.0:
        return at
    change = U[row, 1] - U[row, 0]
    return float(np.clip(ends[0] + (change - D[row, 1] * (ends[1] - ends[0])) / jump, ends[0], ends[1]))


def penalized_inputs(solution) -> set[str]:
    """The inputs the objective's integrand is strictly convex in (its second derivative in each positive at every
    point: an effort term): they cannot jump from one bound to the other. The optimal input minimizes a Hamiltonian
    strictly convex in it, so it follows the costates continuously, however steeply (a sixth newcomer's pendulum
    tracking a steep reference with 0.01 of effort: its torque goes from +5 to -5 N m in 47 ms; read as a jump,
    the window left out of the multipliers' estimate hid an error 3.3x the estimate, and no mesh resolved it)."""
    pr = getattr(solution.transcription, "user_problem", solution.transcription.problem)
    e = pr.eqs
    if not pr.integral_terms or not e.inputs.numel():
        return set()
    # Built once per objective (kept on the problem; an edited objective has other terms, so another key).
    key = tuple((id(term.expression), term.weight) for term in pr.integral_terms)
    cached = pr.__dict__.get("_input_curvature")
    if cached is None or cached[0] != key:
        integrand = sum(term.weight * term.expression for term in pr.integral_terms)
        curvature = ca.diag(ca.hessian(integrand, e.inputs)[0])
        cached = pr.__dict__["_input_curvature"] = (key, ca.Function("curvature", [e.q, e.u, e.inputs, pr.lam, e.t],
                                                                     [curvature]))
    traj, t = solution.trajectory, solution.t
    f = cached[1].map(len(t))
    c = np.asarray(f(np.asarray(traj.q).T, np.asarray(traj.u).T, np.asarray(traj.inputs).T, np.asarray(traj.lam).T,
                     t[None, :])).reshape(e.inputs.numel(), len(t))
    return {name for name, row in zip(pr.model.inputs, c) if np.all(row > 0.0)}


def detect_switches(solution) -> list[Switch]:
    """Every switch of every bounded quantity of ``solution``, located (module notes), in time order.

    The first point (``t = 0``) is left out for inputs and path constraints: Radau has no collocation
    point there, its inputs are extrapolated and its multipliers follow from the acceleration level.
    Kept on the solution for the bounds and path constraints it was found under (a refinement reads a
    solution's switches up to three times: as a companion, as the next solution, as the one returned);
    an edit of the problem's bounds or path constraints finds them again."""
    pr = getattr(solution.transcription, "user_problem", solution.transcription.problem)
    key = (tuple(pr.bounds.items()), tuple((id(c), c.lower, c.upper) for c in pr.path_constraints))
    kept = solution.__dict__.get("_switches")
    if kept is None or kept[0] != key:
        kept = solution.__dict__["_switches"] = (key, _on_arcs(_detect(solution), solution))
    return list(kept[1])


def _on_arcs(found: list[Switch], solution) -> list[Switch]:
    """``found``, the junctions of a quantity whose arcs are imposed (:mod:`.imposed_arcs`) put at their mesh points, where
    they are by construction: located from the points, they fall a little inside the free interval next to them, and
    read as kinks inside it they floored the estimate at the kink's size (the torque-limited rod at 1e-5: 1.3e-2 of
    the load, halving with each refinement, against a true error of 1e-7)."""
    arcs = getattr(solution.transcription, "arcs", ())
    mesh = solution.transcription.scheme.mesh_fractions
    ends: dict = {}
    for a in arcs:      # in fractions of the horizon
        ends.setdefault(a.quantity, []).extend(x for x in (a.start, a.end) if 0.0 < x < 1.0)
    # A bang-bang input's arcs meet at its jumps, free mesh points (.jump_arcs): its jumps are there too.
    jumping = set(imposed_jumps(solution.transcription).values())
    out = []
    for w in found:
        if (w.kind == "junction" or w.quantity in jumping) and ends.get(w.quantity):
            at = min(ends[w.quantity], key=lambda x: abs(x - w.fraction))
            k = int(np.clip(np.searchsorted(mesh, at * (1 + 1e-12), side="right") - 1, 0, len(mesh) - 2))
            w = replace(w, fraction=at, interval=k, inside=False, effect=0.0, imposed=True)
        out.append(w)
    return out


def _detect(solution) -> list[Switch]:
    tr = solution.transcription
    mesh, frac = tr.scheme.mesh_fractions, tr.fractions
    D, X, T = np.asarray(solution.D, float), np.asarray(solution.X, float), float(solution.t_final)
    U = X[X.shape[0] - D.shape[0]:]                # the speeds, whose rates D holds
    first = frac[tr.offsets[:-1] + 1]              # each interval's first collocation point
    # Each point's interval (a mesh point ends the interval before it, whose last collocation point it is).
    interval_of = np.clip(np.searchsorted(mesh, frac, side="left") - 1, 0, tr.scheme.intervals - 1)
    out = []
    bounds = getattr(tr, "user_problem", tr.problem).bounds
    quantities = bounded_quantities(solution)
    smooth = None
    for name, v, lo, hi, states_only, continuous in quantities:
        source = ("state" if states_only else "input") if name in bounds else "path"
        s, eps = activity(v, lo, hi)
        idx = np.arange(0 if states_only else 1, len(v))
        if len(np.unique(s[idx])) < 2:
            continue
        # Only where a quantity switches (the integrand's curvature at every point costs ~1 ms a solution).
        smooth = penalized_inputs(solution) if smooth is None else smooth
        # A continuous quantity (a state, a path constraint of states) approaches its bound tangentially (_approach).
        for at, kind, i, j in locate(frac[idx], v[idx], s[idx], lo, hi, eps, jumps=not continuous and name not in smooth,
                                     intervals=interval_of[idx], through_active=True,
                                     tight=eps * TIGHT / ACTIVE if continuous else None):
            k = int(np.clip(np.searchsorted(mesh, at, side="right") - 1, 0, tr.scheme.intervals - 1))
            # Before the middle of the gap to the first collocation point: at the mesh point.
            inside = at - mesh[k] > 0.5 * (first[k] - mesh[k]) * (1.0 + 1e-9)
            if kind == "bang-bang":     # the bracket of a jump takes in the points where its bounds are held loosely
                tight = eps * TIGHT / ACTIVE
                i, j = _loose(v[idx], s[idx], i, -1, tight, lo, hi), _loose(v[idx], s[idx], j, 1, tight, lo, hi)
            pi, pj = idx[i], idx[j]
            if not inside and pj == pi + 1 and frac[pi] == mesh[k]:
                # A clean switch at the mesh point: the point at it on one bound (the interval before's, as Radau's
                # inputs there are), the next on the other; it strays by nothing (the bang-bang block of
                # scripts/refinement_holdouts.py, its switch at T/2 on every mesh: the trapezoids across the gap
                # made an "effect" of 6.9e-2 m/s where the true state error was 4e-9).
                at, effect = float(mesh[k]), 0.0
            elif kind == "junction":
                # A kink (an input's, a path constraint's or a state bound's), located where its approach meets the
                # bound (to 2e-6 of the horizon on the speed-limited block of tests/test_refinement_junctions.py):
                # the accelerations are continuous there, and a jump's effect (their change across the bracket times
                # its distance from a mesh point) made the states' estimate 15x their true error (that block), and
                # 12-100x on an input's junctions (the fourth newcomer's least-time arm, results/bench/
                # refinement_newcomer4.md). The inputs' and multipliers' estimates keep the kink's floor (error_estimate).
                effect = 0.0
            else:
                effect = (_effect(frac[pi : pj + 1] * T, D[:, pi : pj + 1], U[:, pi : pj + 1],
                                  _effective(frac[[pi, pj]] * T, D[:, [pi, pj]], U[:, [pi, pj]], at * T), mesh, T)
                          if D.size else 0.0)
            out.append(Switch(float(at), k, bool(inside), name, kind, (float(frac[pi]), float(frac[pj])), effect, source))
    return sorted(out, key=lambda w: w.fraction)


def touched(switches: list[Switch], mesh: np.ndarray) -> np.ndarray:
    """Per interval of ``mesh``: whether the bracket of a located switch overlaps it. There the inputs or
    multipliers are not smooth because of that switch, which splitting has placed (or will place) at a
    mesh point; halving such an interval again only shortens it, and on short intervals next to a switch
    the NLP holds its bounds loosely (IPOPT's ``mu / lambda``, the bound's multiplier scaling with the
    interval's length), so their values grow noisier, not smoother (rolling-disk drive at 1e-4: 90
    intervals of 1e-5 of the horizon at its friction cone's junction, 127 s CPU)."""
    out = np.zeros(len(mesh) - 1, bool)
    for w in switches:
        out |= (mesh[:-1] < w.bracket[1]) & (mesh[1:] > w.bracket[0])
    return out


def jump_windows(switches: list[Switch], mesh: np.ndarray) -> list[tuple[float, float]]:
    """Where the inputs and multipliers jump, left out of their estimate (:func:`.error_estimate.estimate_error`):
    the mesh intervals (``mesh``, fractions) that the bracket of a jump (``kind == "bang-bang"``) touches.
    The whole interval, because each interval's polynomial through a point inside the jump bends over all
    of it (minimum-time swing-up: 0.08 of the largest load between the last point at the bound and the
    mesh point before it). None for a jump imposed at a free mesh point (``imposed``, :mod:`.jump_arcs`): each side
    is its own interval's polynomial there, in the solution and in its companion alike (:func:`.error_estimate.values_at`),
    and the interval after the jump is judged like any other (in maximal coordinates its hinge force, left out, was
    1.1e-5 of the largest load off at its end, and the next interval's estimate stayed there through ten halvings)."""
    out = []
    for w in switches:
        if w.kind == "bang-bang" and not w.imposed:
            lo = mesh[max(np.searchsorted(mesh, w.bracket[0], side="right") - 1, 0)]
            hi = mesh[min(np.searchsorted(mesh, w.bracket[1], side="left"), len(mesh) - 1)]
            out.append((float(lo), float(hi)))
    return out


def split_points(switches: list[Switch], mesh: np.ndarray, min_piece: float, tolerance: float,
                 ratio: np.ndarray) -> dict[int, list[float]]:
    """Per interval, the fractions to split it at: the switches inside it that matter, those of several
    quantities within :data:`MERGE` of the interval's length merged into one (their mean), none that
    would leave a piece shorter than ``min_piece`` (a fraction of the horizon).

    A jump between bounds matters while its ``effect`` exceeds half the ``tolerance``: with the jump at
    the nearest mesh point instead of where it was located, the speeds then move by less than that, and
    a mesh point closer still only makes the NLP's inputs there arbitrary (over a few microseconds the
    objective hardly depends on them; the minimum-time swing-up split at every such value ended on 94
    intervals). A junction (a kink, the
    values continuous) matters where its interval's estimate is above the tolerance (``ratio[k] > 1``):
    its error is of the size the companion sees, and splitting at the kink beats raising the degree;
    not on intervals shorter than :data:`JUNCTION_MIN`, where "junctions" are mostly a bound held loosely
    next to a jump (minimum-time swing-up at 1e-4: 128 intervals chasing them), nor within
    :data:`JUNCTION_NEAR` of the interval's length from its ends: a junction located again after a split
    lies that close to the mesh point put at it (four-bar's pin force: 0.1851, 0.1849, 0.1848 of the
    horizon, a ladder of mesh points 2e-4 apart where one serves)."""
    by_interval: dict[int, list[float]] = {}
    for w in switches:
        a, b = mesh[w.interval], mesh[w.interval + 1]
        matters = (w.effect > 0.5 * tolerance if w.kind == "bang-bang"
                   else SPLIT_JUNCTIONS and ratio[w.interval] > 1.0 and b - a > JUNCTION_MIN
                   and min(w.fraction - a, b - w.fraction) > JUNCTION_NEAR * (b - a))
        if w.inside and matters:
            by_interval.setdefault(w.interval, []).append(w.fraction)
    out = {}
    for k, points in by_interval.items():
        a, b = float(mesh[k]), float(mesh[k + 1])
        groups: list[list[float]] = []
        for p in sorted(points):
            if groups and p - groups[-1][-1] <= MERGE * (b - a):
                groups[-1].append(p)
            else:
                groups.append([p])
        cuts, last = [], a
        for g in groups:
            p = float(np.mean(g))
            if p - last >= min_piece and b - p >= min_piece:
                cuts.append(p)
                last = p
        if cuts:
            out[k] = cuts
    return out


def record_switches(solution, record: dict):
    """Put every switch located on ``solution`` (the one a refinement returns) in its ``record`` as
    ``"switches_located"``: quantity, kind (``"junction"`` or ``"bang-bang"``), source, time (s), fraction of the
    horizon, and whether it lies inside an interval; ``solution`` returned as it is. A user told to put a mesh point
    at a switch (``Radau(mesh=...)``) reads its time here (a fifth newcomer found it only in the message, to three
    digits)."""
    T = float(solution.t_final)
    record["switches_located"] = [{"quantity": w.quantity, "kind": w.kind, "source": w.source, "t": w.fraction * T,
                                   "fraction": w.fraction, "inside": w.inside} for w in detect_switches(solution)]
    return solution
