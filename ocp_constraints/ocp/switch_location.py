"""Locating a switch between the points of one bounded quantity (issue 19): a jump between its bounds or a
junction between a bound and a free arc, from the values at the points and their activity
(:func:`.switch_detection.activity`). :mod:`.switch_detection` reads the quantities off a solution and places each
switch on the mesh; the module notes there say how a switch is located and why.
"""
from __future__ import annotations

import numpy as np

# A free run beside one bound is an arc (two junctions) only if it leaves the bound by more than this
# many activity thresholds (:func:`locate`).
ARC = 10.0
# A free run of an input between its two bounds is one jump (smeared by the NLP) only if its points lie in at most two
# mesh intervals or within this fraction of the horizon; else a continuous arc with a junction at each end (F =
# clip(a - b t, -U, U): a free arc over 0.8 of the horizon, taken for a jump, left the inputs and multipliers out of
# their estimate there; scripts/refinement_holdouts.py).
JUMP_SPAN = 0.01


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


def _approach(v: np.ndarray, bound: float, active: int, free: list[int], step: int, tight: float) -> list[int]:
    """``free`` (nearest first) after the active run's points from ``active`` on that are still more than ``tight`` off
    the bound, nearest the junction first: a tangential approach is "active" long before it (a fifth newcomer's arm
    angle bound: ~0.1 s), and the line through the free points beyond met the bound 4.5 ms late, an interval past
    the kink; through the approach's own points, 0.1 ms (``results/bench/refinement_newcomer5.md``)."""
    near, i = [], active
    while 0 <= i < len(v) and abs(v[i] - bound) > tight:
        near.append(i)
        i -= step
    return near[::-1] + list(free) if near else list(free)


def _junction_switch(t: np.ndarray, v: np.ndarray, s: np.ndarray, bound: float, active: int, free: list[int],
                     through_active: bool, tight: float | None = None) -> tuple[float, str, int, int]:
    """The junction between the active point ``active`` and the free run ``free`` (nearest first), as
    :func:`locate` gives it: where :func:`_junction` puts it, and the two points around it (``through_active``
    and behind ``active``, in its active run), else ``active`` and the nearest free point, in time order.
    ``tight``: the active run's points farther than this from the bound are drawn through as free ones
    (:func:`_approach`)."""
    step = 1 if free[0] > active else -1            # from the active run towards the free one
    if tight is not None:
        free = _approach(v, bound, active, free, step, tight)
    # With one free point no line is drawn: the junction lies between it and its active neighbour, not half-way
    # back along the active run (an input held on one bound and then the other across one free point, 0.34 of
    # the horizon, was put at 0.17 and 0.66).
    at = _junction(t, v, bound, _reach(s, active, -step) if through_active and len(free) >= 2 else active, free)
    if through_active and (t[active] - at) * step > 0:
        if step > 0:
            k = int(np.flatnonzero(t <= at)[-1])
            return at, "junction", k, k + 1
        k = int(np.flatnonzero(t >= at)[0])
        return at, "junction", k - 1, k
    return (at, "junction", active, free[0]) if step > 0 else (at, "junction", free[0], active)


def locate(t: np.ndarray, v: np.ndarray, s: np.ndarray, lower: float, upper: float,
           eps: float, jumps: bool = True, intervals: np.ndarray | None = None,
           through_active: bool = False, tight: float | None = None) -> list[tuple[float, str, int, int]]:
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
    ``tight``: for a continuous quantity, the active run's points still farther than this from the bound are drawn
    through as the approach's (:func:`_approach`). ``through_active``: a junction may lie anywhere back along the active run, not only between its last
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
                    found.append(_junction_switch(t, v, s, bound, active, free, through_active, tight))
        i = j + 1
    return found
