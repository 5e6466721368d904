"""When mesh refinement has stopped paying: the stall rule of :func:`~.mesh_refinement.solve_to_tolerance`.

Where the solution is smooth, halving an interval of degree ``p`` divides its error by about
``2^(p+1)`` (16 at degree 3, 256 at degree 7; Patterson & Rao 2014), and raising the degree
divides it geometrically; even at a kink, halving divides it by 2-4. So a refinement that makes
the mesh much larger should cut the estimate by at least as much as it multiplied the points. When
it does not, the solution and its companion are not converging together (a singular or
non-unique arc, a path constraint's junction the mesh cannot resolve, a local optimum that moves
with the mesh), and every further refinement costs more than the last for little gain: the
four-bar of the suite at 1e-4 went 883 -> 1,709 points for an estimate 1.5e-2 -> 1.1e-2, then
3,361 points and 470 s of CPU for 2.3e-2 (it stops there now), and on for as long as
``max_refinements`` (10) let it.

It stops after two such refinements in a row (one can stall while the mesh moves to a switch), and
looks only at refinements after the first (the first mesh is coarse, its estimate
pre-asymptotic) that grew the mesh by at least :data:`STALL_GROWTH`: the small
steps of a refinement that splits a few intervals at switches (the walker, the minimum-time
swing-up, 1.02-1.25x the points) may leave the estimate flat for one step and then meet the
tolerance, and are not judged by it.
"""
from __future__ import annotations

STALL_GROWTH = 1.5      # a refinement that multiplied the points by at least this is judged by the rule


def _largest(entry: dict, quantities) -> float:
    return max(float(entry["estimate"][q]) for q in quantities)


def _stalled_step(prev: dict, cur: dict, quantities) -> tuple[float, float, float, float] | None:
    """``(growth, fall, before, after)`` of the refinement ``prev -> cur`` if it stalled, else ``None``."""
    if not (prev.get("resolved", True) and cur.get("resolved", True)) or "estimate" not in prev or "estimate" not in cur:
        return None
    growth = cur["points"] / prev["points"]
    before, after = _largest(prev, quantities), _largest(cur, quantities)
    fall = before / after if after > 0 else float("inf")
    return (growth, fall, before, after) if growth >= STALL_GROWTH and fall < growth else None


def stall_message(history: list[dict], tol: float, quantities=("states", "multipliers")) -> str | None:
    """Why refinement should stop now, or ``None`` to go on.

    ``history``: the refinement's entries so far (each with ``points``, ``estimate`` per quantity and
    ``resolved``), the last one just estimated. A refinement (not the first) *stalls* when it multiplied
    the points by ``growth >= STALL_GROWTH`` and divided the largest estimate of ``quantities`` by less
    than ``growth``; refinement stops after two stalls in a row. One is not enough: while the mesh moves
    to a switch it can stall once and then converge (the suite's rolling disk at 1e-3: 71 -> 141 points
    for an estimate 1.8x lower, then 239 points 6.2x lower, met at 246).
    """
    if len(history) < 4:    # the first mesh is pre-asymptotic: the rolling disk's first refinement (31 -> 71
        return None         # points) cut its estimate only 2.1x, and the next met 1e-3 (92 points)
    first = _stalled_step(history[-3], history[-2], quantities)
    last = _stalled_step(history[-2], history[-1], quantities)
    if first is None or last is None:
        return None
    growth, fall, before, after = last
    worst = history[-1].get("worst", {})
    where = ", ".join(f"{q}: {worst[q]}" for q in quantities if q in worst)
    return (f"refinement stalled: the last two refinements grew the mesh {first[0]:.1f}x and {growth:.1f}x "
            f"({history[-3]['points']} -> {history[-2]['points']} -> {history[-1]['points']} points) and changed the "
            f"estimate only {first[1]:.2g}x and {fall:.2g}x ({first[2]:.1e} -> {before:.1e} -> {after:.1e}), where a "
            f"converging solution's falls faster than its points grow; the solution and its companion do not "
            f"converge together here (largest differences: {where}), so more points would cost more than the last "
            f"and are unlikely to reach {tol:.0e}. The last solution is returned with its estimate: accept a "
            f"tolerance of about {min(before, after):.0e}, or look for a singular or non-unique arc, a path "
            f"constraint's junction or a local optimum that moves with the mesh")
