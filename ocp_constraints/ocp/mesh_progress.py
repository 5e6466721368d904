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

The rule judges the last two refinements together (one can stall while the mesh moves to a switch),
never the first refinement (the first mesh is coarse, its estimate pre-asymptotic), and only where
the two grew the mesh by at least :data:`STALL_GROWTH`: the small steps of a refinement that splits a
few intervals at switches (the walker, the minimum-time swing-up, 1.02-1.25x the points) may leave
the estimate flat for a step and then meet the tolerance, and are not judged by it.
"""
from __future__ import annotations

STALL_GROWTH = 2.0      # two refinements that multiplied the points by at least this are judged by the rule


def _largest(entry: dict, quantities) -> float:
    return max(float(entry["estimate"][q]) for q in quantities)


def stall_message(history: list[dict], tol: float, quantities=("states", "multipliers")) -> str | None:
    """Why refinement should stop now, or ``None`` to go on.

    ``history``: the refinement's entries so far (each with ``points``, ``estimate`` per quantity and
    ``resolved``), the last one just estimated. Over the last two refinements (neither of them the
    first), if the points grew by ``growth >= STALL_GROWTH`` and the largest estimate of ``quantities``
    fell by less than ``growth``, refinement has stalled. Two refinements, not one: while the mesh moves
    to a switch one refinement can stall and the next converge (the suite's rolling disk at 1e-3: 71 ->
    141 points for an estimate 1.8x lower, then 239 points 6.2x lower, met at 246); and two, not "two
    stalls in a row", so that a small step between them does not hide a stall (the rolling disk's drive
    at 1e-5: 141 -> 281 points 0.9x lower, 281 -> 547 2.75x lower, then small steps, a jump of the
    estimate to 1.1e-2 and 1,889 and 5,164 points, past 540 s of CPU).
    """
    if len(history) < 4:    # the first mesh is pre-asymptotic: the rolling disk's first refinement (31 -> 71
        return None         # points) cut its estimate only 2.1x, and the next met 1e-3 (92 points)
    window = history[-3:]
    if any(not e.get("resolved", True) or "estimate" not in e for e in window):
        return None
    start, end = window[0], window[-1]
    growth = end["points"] / start["points"]
    before, after = _largest(start, quantities), _largest(end, quantities)
    fall = before / after if after > 0 else float("inf")
    if growth < STALL_GROWTH or fall >= growth:
        return None
    worst = end.get("worst", {})
    where = ", ".join(f"{q}: {worst[q]}" for q in quantities if q in worst)
    best = min(_largest(e, quantities) for e in history[1:])
    return (f"refinement stalled: the last two refinements grew the mesh {growth:.1f}x ("
            f"{' -> '.join(str(e['points']) for e in window)} points) and changed the estimate only {fall:.2g}x "
            f"({' -> '.join(f'{_largest(e, quantities):.1e}' for e in window)}), where a converging solution's falls "
            f"faster than its points grow; the solution and its companion do not converge together here (largest "
            f"differences: {where}), so more points would cost more than the last and are unlikely to reach "
            f"{tol:.0e}. The last solution is returned with its estimate (the lowest reached: {best:.1e}): accept a "
            f"larger tolerance, or look for a singular or non-unique arc, a path constraint's junction or a local "
            f"optimum that moves with the mesh")
