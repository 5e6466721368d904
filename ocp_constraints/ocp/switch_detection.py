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
  nearest lies on most closely (:func:`_junction`), anywhere back along the run of points counted
  active (within the activity threshold a tangential approach looks active early).

A switch located in the first half of the gap between an interval's start and its first collocation
point is *at the mesh point*: Radau's inputs at the mesh point are the interval before's, so a jump
exactly at a mesh point shows as a clean change there. Any other switch lies *inside* its interval.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

# A value within this fraction of the quantity's scale (the larger of its finite bounds' magnitudes and
# its span over the horizon) of a bound is active. IPOPT's interior point leaves a bound by mu / lambda,
# larger where the multiplier is small near a switch (the minimum-time swing-up's torque: 4.996 at a
# bound of 5 next to the switch, 4e-4 of its span of 10); a free value half-way (0.28) is far from it.
ACTIVE = 2e-3
# A free run beside one bound is an arc (two junctions) only if it leaves the bound by more than this
# many activity thresholds (:func:`locate`).
ARC = 10.0
# Within this fraction of the scale a bound is held tightly; between TIGHT and ACTIVE loosely (_loose).
TIGHT = 1e-5
# Fraction of the horizon below which an interval is not split at a junction (split_points).
JUNCTION_MIN = 1e-3
# Whether junctions (kinks) split intervals too. Measured, they do not pay yet: the walker at 1e-4 took
# 14 solves to 617 points, 136 s CPU (11 solves to 323 points, 69 s without), the rolling-disk drive at
# 1e-4 ended in IPOPT's Restoration_Failed on 51 intervals, the four-bar was still at 3.2e-4 (states) and
# 1.4e-3 (multipliers) after 3 refinements, 256 intervals, 145 s CPU; jumps do pay (split_points).
SPLIT_JUNCTIONS = False
# A junction closer than this fraction of its interval to one of the interval's ends is at that mesh point.
JUNCTION_NEAR = 0.05
# Switches of several quantities closer than this fraction of their interval are one switch.
MERGE = 0.02
# A free run of an input between its two bounds is one jump (smeared by the NLP) only if its points lie in at
# most two mesh intervals or within this fraction of the horizon; else it is a continuous arc with a junction
# at each end (minimum effort under a force limit, F = clip(a - b t, -U, U): a free arc over 0.8 of the horizon,
# taken for a jump, left the inputs and multipliers out of their estimate there; scripts/refinement_holdouts.py).
JUMP_SPAN = 0.01


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
    mesh point sits at the nearest one."""

    fraction: float
    interval: int
    inside: bool
    quantity: str
    kind: str
    bracket: tuple[float, float] = (0.0, 0.0)
    effect: float = 0.0
    source: str = "path"


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


def _junction(t: np.ndarray, v: np.ndarray, bound: float, active: int, free: list[int]) -> float:
    """Where the free points ``free`` (nearest first) reach ``bound``, kept between the active point ``active``
    and the nearest free point (their midpoint if the free points do not help). A quantity leaves a bound
    with a slope (an input; its distance ``d`` from the bound linear in time) or tangentially (a speed
    limit, a load that follows the speeds: ``d`` quadratic, ``sqrt(d)`` linear; a position bound reached with
    zero speed and acceleration, ``d`` cubic, ``cbrt(d)`` linear); the line through the two nearest free points
    is drawn for ``d``, ``sqrt(d)`` and ``cbrt(d)``, and the one on which the third nearest lies most closely is
    taken (with two free points, ``d``'s). Drawn for ``d`` alone, a tangential approach reaches the bound early:
    the hinge's speed limit of scripts/refinement_holdouts.py (Radau 5 to 7, 1e-3), at 0.625 s for 0.6438 s, a
    mesh point before the kink's interval; drawn for ``sqrt(d)`` at most, Bryson-Denham's wall (junctions at 1/3
    and 2/3 of the horizon) was located at 0.3033 and 0.6982, now 0.33333 and 0.66666."""
    lo, hi = sorted((t[active], t[free[0]]))
    if len(free) < 2:
        return 0.5 * (lo + hi)
    d = np.abs(v[free[:3]] - bound)
    fits = []       # (how far the third point is off the line, relative; where the line reaches zero)
    for y in (d, np.sqrt(d), np.cbrt(d)) if len(free) >= 3 else (d,):
        if y[1] != y[0]:
            slope = (y[1] - y[0]) / (t[free[1]] - t[free[0]])
            at = t[free[0]] - y[0] / slope
            off = abs(y[0] + slope * (t[free[2]] - t[free[0]]) - y[2]) / float(y.max()) if len(y) > 2 else 0.0
            if np.isfinite(at):
                fits.append((off, at))
    return float(min(max(min(fits)[1], lo), hi)) if fits else 0.5 * (lo + hi)


def _crossing(t: np.ndarray, v: np.ndarray, level: float, i: int, j: int) -> float:
    """Where the piecewise-linear interpolation of points ``i..j`` first crosses ``level``."""
    for a in range(i, j):
        if (v[a] - level) * (v[a + 1] - level) <= 0 and v[a] != v[a + 1]:
            return float(t[a] + (level - v[a]) / (v[a + 1] - v[a]) * (t[a + 1] - t[a]))
    return 0.5 * float(t[i] + t[j])


def _reach(s: np.ndarray, i: int, step: int) -> int:
    """From the active point ``i``, the last point of its run of points active at the same bound, in direction ``step``."""
    while 0 <= i + step < len(s) and s[i + step] == s[i]:
        i += step
    return i


def _junction_switch(t: np.ndarray, v: np.ndarray, s: np.ndarray, bound: float, active: int, free: list[int],
                     through_active: bool) -> tuple[float, str, int, int]:
    """The junction between the active point ``active`` and the free run ``free`` (nearest first), as
    :func:`locate` gives it: where :func:`_junction` puts it, and the two points around it (``through_active``
    and behind ``active``, in its active run), else ``active`` and the nearest free point, in time order."""
    step = 1 if free[0] > active else -1            # from the active run towards the free one
    at = _junction(t, v, bound, _reach(s, active, -step) if through_active else active, free)
    if through_active and (t[active] - at) * step > 0:
        if step > 0:
            k = int(np.flatnonzero(t <= at)[-1])
            return at, "junction", k, k + 1
        k = int(np.flatnonzero(t >= at)[0])
        return at, "junction", k - 1, k
    return (at, "junction", active, free[0]) if step > 0 else (at, "junction", free[0], active)


def locate(t: np.ndarray, v: np.ndarray, s: np.ndarray, lower: float, upper: float,
           eps: float, jumps: bool = True, intervals: np.ndarray | None = None,
           through_active: bool = False) -> list[tuple[float, str, int, int]]:
    """The switches between points ``t`` (in time order) of values ``v`` with activity ``s``:
    ``(where, kind, i, j)``, the switch between points ``i`` and ``j`` (their activities differ). A run
    of free points between the two bounds is one jump (bang-bang), however many points and intervals it
    spans: on very short intervals next to a jump the NLP's inputs are nearly arbitrary, the objective
    hardly depends on them. Only a quantity that can jump (``jumps``: an input, or a path constraint of
    inputs or multipliers) jumps; a continuous one (a coordinate, a speed, a path constraint of those
    alone: :func:`bounded_quantities`) crosses from one bound to the other along a free arc, two junctions
    (a UR5 elbow's speed limit, +3.15 rad/s held over 0.06-0.23 of the horizon, then 2.86, 2.23, ... down
    to -3.15 from 0.5 on: taken as a jump, its bracket was the whole free arc and its "effect", 5.6 rad/s,
    the speeds' estimate at every mesh); between two neighbouring points at opposite bounds, one junction
    at their middle (the arc between them is not resolved). With ``intervals`` (each point's mesh interval), a
    free run of a quantity that can jump is one jump only where the NLP can have smeared one: its points in at
    most two intervals, or within :data:`JUMP_SPAN` of the horizon (a run of very short intervals at a jump);
    a longer run is a continuous arc between the bounds, two junctions (:data:`JUMP_SPAN`).
    ``through_active``: a junction may lie anywhere back along the active run, not only between its last
    point and the first free one, and the junction's bracket is then the two points around it. Free points
    within the activity threshold of the bound count as active, so the last "active" point can lie past the
    junction (the push clipped at F <= 5.4 N, refined to 1e-4: located at 0.0574 of the horizon for 0.05556,
    an interval late, which left the kink's interval without its estimate's kink floor; now at 0.0555555;
    a tangential approach, :func:`_junction`, counts as active even longer). A free run next to one bound
    counts (two junctions) only if it leaves the
    bound by more than :data:`ARC` times ``eps`` (the activity threshold): else the bound is held loosely,
    IPOPT's ``mu / lambda`` where the bound's multiplier is small (on short intervals, whose multipliers
    scale with their length, and next to a switch, where the switching function vanishes)."""
    found, n, i = [], len(t), 0
    # Each maximal run of free points, with its active neighbours (if any) on either side.
    while i < n:
        if s[i] != 0:
            if i + 1 < n and s[i + 1] != 0 and s[i + 1] != s[i]:           # one bound straight to the other
                found.append((0.5 * float(t[i] + t[i + 1]), "bang-bang" if jumps else "junction", i, i + 1))
            i += 1
            continue
        j = i
        while j + 1 < n and s[j + 1] == 0:
            j += 1
        left = i - 1 if i > 0 else None
        right = j + 1 if j + 1 < n else None
        between = left is not None and right is not None and s[left] == -s[right]
        smeared = (intervals is None or len(np.unique(intervals[i : j + 1])) <= 2
                   or t[j] - t[i] <= JUMP_SPAN)
        if jumps and between and smeared:
            found.append((_crossing(t, v, 0.5 * (lower + upper), left, right), "bang-bang", left, right))
        # a continuous arc from one bound to the other, or a run that leaves its one bound for real: its junctions
        elif between or np.abs(v[i : j + 1] - (lower if s[left if left is not None else right] < 0
                                                else upper)).max() > ARC * eps:
            run = list(range(i, j + 1))
            for active, free in ((left, run), (right, run[::-1])):
                if active is not None:
                    bound = lower if s[active] < 0 else upper
                    found.append(_junction_switch(t, v, s, bound, active, free, through_active))
        i = j + 1
    return found


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


def _effect(t: np.ndarray, D: np.ndarray, at: float, mesh: np.ndarray, T: float) -> float:
    """How far the speeds (m/s, rad/s; the NLP's) stray from a clean switch at ``at`` (s) across a bracket:
    the largest ``|integral (u' - u'_clean) dt|`` from its first point ``t[0]`` (trapezoids on the points),
    ``u'_clean`` the accelerations of the bracket's ends before and after ``at``; and, if ``at`` is no
    mesh point, the jump of the accelerations times its distance from the nearest one (where a clean
    jump at that mesh point would put it)."""
    clean = np.where(t[None, :] < at, D[:, :1], D[:, -1:])
    drift = np.concatenate([np.zeros((D.shape[0], 1)),
                            np.cumsum(0.5 * (np.diff(t) * (D - clean)[:, 1:] + np.diff(t) * (D - clean)[:, :-1]), axis=1)], axis=1)
    misplaced = float(np.abs(D[:, -1] - D[:, 0]).max()) * float(np.abs(mesh * T - at).min())
    return max(float(np.abs(drift).max()), misplaced)


def detect_switches(solution) -> list[Switch]:
    """Every switch of every bounded quantity of ``solution``, located (module notes), in time order.

    The first point (``t = 0``) is left out for inputs and path constraints: Radau has no collocation
    point there, its inputs are extrapolated and its multipliers follow from the acceleration level."""
    tr = solution.transcription
    mesh, frac = tr.scheme.mesh_fractions, tr.fractions
    D, T = np.asarray(solution.D, float), float(solution.t_final)
    first = frac[tr.offsets[:-1] + 1]              # each interval's first collocation point
    # Each point's interval (a mesh point ends the interval before it, whose last collocation point it is).
    interval_of = np.clip(np.searchsorted(mesh, frac, side="left") - 1, 0, tr.scheme.intervals - 1)
    out = []
    bounds = getattr(tr, "user_problem", tr.problem).bounds
    for name, v, lo, hi, states_only, continuous in bounded_quantities(solution):
        source = ("state" if states_only else "input") if name in bounds else "path"
        s, eps = activity(v, lo, hi)
        idx = np.arange(0 if states_only else 1, len(v))
        if len(np.unique(s[idx])) < 2:
            continue
        for at, kind, i, j in locate(frac[idx], v[idx], s[idx], lo, hi, eps, jumps=not continuous,
                                     intervals=interval_of[idx], through_active=True):
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
                effect = _effect(frac[pi : pj + 1] * T, D[:, pi : pj + 1], at * T, mesh, T) if D.size else 0.0
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
    mesh point before it)."""
    out = []
    for w in switches:
        if w.kind == "bang-bang":
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

