"""The junction times of imposed arcs, an input's or a path constraint's, found as roots (issue 19; the arcs and
why: :mod:`.imposed_arcs`).

A refinement that has located such an arc on its bound (a solution resolved, not yet within the tolerance) tries once
to impose it: every inner junction becomes a mesh point, and its time is moved by secant steps, each a warm solve of
the mesh with the arcs imposed, until the quantity's continuity mismatch there (:func:`.imposed_arcs.mismatch`) is
below :data:`GOAL` times the tolerance. The first step moves by :data:`FIRST_STEP` of the junction's interval, in the
direction the mismatch points to (a free side above an upper bound after an arc's end: the arc ends later), or, where
the previous mesh's placement left its slopes, is a Newton step on them. A secant step after which the mismatch has
grown is halved (:data:`GROWTH`), and every step starts warm from the solution of the smallest mismatch yet: next to
a junction the imposed NLP can have a second optimum that uses the bound dropped there. The arcs
are kept only if they hold (:func:`holds`): the free side within the bounds where they were dropped, and each arc's
multiplier pushing the quantity against its bound (IPOPT's ``lam_x`` or ``lam_g``: >= 0 on an upper bound, <= 0 on a
lower), not pulling it off. Otherwise, or where a step's solve fails or the steps run out, the refinement goes on
without them. Every later solve, the companion's too, moves its own junctions so (:func:`solve_on_arcs`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ModelError, OCPSolveError
from .arc_handoffs import tied
from .imposed_arcs import find_arcs, inner_junctions, is_touch, mismatch, on_rows, pinned, pinned_points, values_of
from .free_mesh_points import with_junction_points
from .jump_arcs import find_jumps, solve_jumps
from .mesh_solves import timed_solve

STEPS = 12          # secant steps at most (the sixth newcomer's tracking pendulum, 5 junctions from its first mesh: 10)
FIRST_STEP = 0.05   # the second trial time: this fraction of the junction's interval away from the located one
GOAL = 0.01         # each junction's mismatch asked: this fraction of the tolerance (relative to the input's scale)
PULL = 1e-3         # an arc's bound multiplier of the wrong sign beyond this fraction of its largest: the arc does not hold
# Arc structures tried at most per refinement: where none holds (the least-time crane and cart-pole, whose imposed solves
# do not solve), each try costs up to STEPS warm solves; with no limit they took 20-25% more CPU at 1e-4 and 1e-5.
TRIES = 2
# A structure tried before is tried again once the estimate has fallen this much since (at most once more): found on a
# mesh that barely resolved the motion, its junctions can be too far off for the secant. A newcomer's cart-pole under a
# hinge-force bound, its arc tried at estimates 2.2 and 0.95 and never again: 1e-4 met on 1,583 points in 28 s of CPU;
# tried again at 0.04, on 624 points in 4 s.
RETRY_DROP = 0.1
# And each time its junctions are located this much more precisely than at its last try (the gap between the
# collocation points around each, the largest): a near bang-bang input's arcs found on a coarse mesh, their junctions
# 2% of the horizon off, can lead the secant to a second root (the fourteenth newcomer's least-time pendulum with
# effort 1e-6), while the estimate stays at the size of the input's jump, whatever the mesh.
RETRY_SHARPER = 0.1
# The first imposition's solves: IPOPT's CPU capped at CAP_FACTOR times the located solution's own solve, MIN_CAP_S at least.
CAP_FACTOR, MIN_CAP_S = 20.0, 2.0
# A secant step after which the largest mismatch has grown more than GROWTH-fold is halved, up to HALVINGS times in a row.
GROWTH, HALVINGS = 2.0, 3


def described(arcs, t_final: float) -> list[dict]:
    """The arcs as the refinement's record gives them: quantity, value, start and end in s, path."""
    return [dict(vars(a), start=a.start * t_final, end=a.end * t_final) for a in arcs]


def _bounds(tr, arc) -> tuple[float, float]:
    """The lower and upper bound of an arc's quantity (an input's or a state's, or a path constraint's)."""
    if arc.path:
        c = next(c for c in tr.nlp_path_constraints if c.label == arc.quantity)
        return c.lower, c.upper
    return getattr(tr, "user_problem", tr.problem).bounds[arc.quantity]


def holds(solution, arcs, scale: dict, tol: float) -> bool:
    """Whether the imposed ``arcs`` are the optimum's (module notes)."""
    tr = solution.transcription
    freed_points = pinned_points(tr, arcs)[1]
    fixed = pinned(tr, arcs)[0]
    for (k, _, _), points in zip(inner_junctions(arcs), freed_points):
        a = arcs[k]
        lo, hi = _bounds(tr, a)
        v = values_of(solution, a)[points]
        slack = GOAL * tol * scale[a.quantity]
        if np.any(v < lo - slack) or np.any(v > hi + slack):
            return False
    for a, idx in zip(arcs, fixed):
        lam = (solution.row_multipliers if on_rows(tr, a) else solution.bound_multipliers)[idx]
        pull = -lam if a.value == _bounds(tr, a)[1] else lam
        # Not the points at an inner junction: the multiplier falls to zero there, and its sign is noise (a rod whose
        # arc of 0.033 s ended at -1.8e-6 of its arc's largest 1.2e-3, and its arcs were dropped).
        # A touch's one point is its junction: its multiplier, an impulse, pushes there.
        # Nor an input's points on the first interval of an arc from t0: Radau's input at t0 is their extrapolation (a
        # row, .transcription_elements), whose multiplier their bounds share with alternating weights (a least-time arm's
        # shoulder torque: +0.09 then -0.06 on its first two points, the arc's largest 0.09, then -2e-6 ... -8e-6).
        first = len(tr.interval_points(0)) - 1 if not (a.state or a.path) else 0
        inner = slice(None) if is_touch(a) else slice(1 if a.start > 0.0 else first, -1 if a.end < 1.0 else None)
        if pull[inner].size and pull[inner].max() > PULL * np.abs(lam).max():
            return False
    return True


@dataclass(frozen=True)
class ArcSet:
    """The arcs a refinement imposes (:mod:`.imposed_arcs`), and each quantity's scale (its bounds' largest magnitude)."""

    arcs: tuple
    scale: dict
    slopes: tuple | None = None     # each junction's mismatch per fraction of the horizon, from the secant that placed it
    jumps: bool = False             # a bang-bang input's arcs: each jump a free mesh point, no secant (.jump_arcs)


def state_offset(g: np.ndarray, slopes, junctions, arcs, solution) -> float | None:
    """How far (s) the junctions of state arcs may still be from their roots, ``|g / slope|``; None where a slope is
    not known. Only a state's junction moves the motion to first order: shifted by ``d`` the states after it move by
    their rate times ``d``, where an input's kink shifted by ``d`` changes the states by its slope change times ``d^2``."""
    state = np.array([arcs[k].state for k, _, _ in junctions], bool)
    if not state.any():
        return 0.0
    if slopes is None or np.any(np.asarray(slopes, float)[state] == 0.0):
        return None
    return float(np.max(np.abs(g[state]) / np.abs(np.asarray(slopes, float)[state]))) * float(solution.t_final)


def _placed(g: np.ndarray, offset: float | None, solution, tol: float) -> bool:
    """Whether the junctions are at their roots closely enough: each mismatch at most :data:`GOAL` times ``tol``, and a
    state's junction's time to its root (:func:`state_offset`, where known) times the speeds' largest rate too. A
    state's touch (the cart-pole's) moves the whole motion after it: a mismatch within the goal left it 1.2e-7 s off
    its root (slope 0.85 per s) and the pole's speed 1.4e-6 rad/s off, 2.9x the estimate, which the companion, its own
    touch as far off, did not see."""
    if np.any(np.abs(g) > GOAL * tol):
        return False
    if not offset:
        return True
    rates = float(np.abs(np.asarray(solution.D, float)).max()) if np.size(solution.D) else 0.0
    return offset * rates <= GOAL * tol


def _gap_around(grid: np.ndarray, at: float) -> float:
    """The length of ``grid``'s interval (mesh points or collocation points, fractions) that holds ``at``."""
    return float(np.diff(grid)[min(max(np.searchsorted(grid, at) - 1, 0), len(grid) - 2)])


def _gaps(times: np.ndarray, quantities: list) -> np.ndarray:
    """Each junction's distance to the nearest other junction of its quantity (inf where it has none)."""
    return np.array([min([abs(times[j] - times[i]) for j in range(len(times)) if j != i and quantities[j] == q]
                         or [np.inf]) for i, q in enumerate(quantities)])


def _in_order(times: np.ndarray, new: np.ndarray, quantities: list) -> np.ndarray:
    """``new`` junction times, the step from ``times`` shortened (halved) until one quantity's junctions keep their
    order, each gap at least a tenth of what it was: the secant treats each junction alone, and of two close ones (a
    short free arc between two arcs of one input, the fourteenth newcomer's least-time block with effort weight 1e-6,
    3.2e-5 of the horizon apart) a step moved an arc's end past the next arc's start, whose points it then freed."""
    pairs = [(i, j) for i in range(len(times)) for j in range(len(times))
             if i != j and quantities[i] == quantities[j] and times[i] < times[j]]
    step = new - times
    for _ in range(30):
        trial = times + step
        if all(trial[j] - trial[i] >= 0.1 * (times[j] - times[i]) for i, j in pairs):
            return trial
        step = step / 2.0
    return times


def solve_on_arcs(problem, scheme, arc_set: ArcSet, tol: float, options: dict, warm, progress, first, fallback,
                  scale_objective):
    """Solve ``scheme`` with ``arc_set`` imposed, its junctions moved (mesh points) by secant steps to the roots of the
    mismatch on this mesh (module notes). Every solve of a refinement does so, the companion too: with the
    solution's junction times imposed on it, the companion shares their error and the estimate misses it (a sixth
    newcomer's pendulum under a torque bound at 1e-4: "met", its hinge force 1.2x the estimate, 6.5e-6 s off a
    junction). Returns ``(solution, wall s, CPU s, mesh, arc_set, converged)``; a step IPOPT does not solve raises
    its :class:`OCPSolveError`."""
    if arc_set.jumps:
        sol, wall, cpu, mesh, arcs = solve_jumps(problem, scheme, arc_set.arcs, options, warm, progress, first, fallback,
                                                 scale_objective)
        return sol, wall, cpu, mesh, replace(arc_set, arcs=arcs), True
    arcs, junctions = list(arc_set.arcs), inner_junctions(list(arc_set.arcs))   # in fractions of the horizon
    times = np.array([at for _, _, at in junctions])
    mesh = scheme.mesh_fractions
    step = FIRST_STEP * np.array([_gap_around(mesh, at) for at in times])
    # Nor more than half the way to the quantity's next junction: a short free arc between two arcs (module notes).
    step = np.minimum(step, 0.5 * _gaps(times, [arcs[k].quantity for k, _, _ in junctions]))
    before, wall, cpu, slopes, halved, probe, best = None, 0.0, 0.0, arc_set.slopes, 0, False, None
    lead = tied(junctions)
    for _ in range(STEPS):
        for (k, side, _), at in zip(junctions, times):
            arcs[k] = replace(arcs[k], **({"start": float(at), "end": float(at)} if side == "touch" else {side: float(at)}))
        trial = with_junction_points(scheme, list(times))
        sol, w, c = timed_solve(problem, trial, options, warm, progress, first, fallback, scale_objective, arcs=arcs)
        wall, cpu = wall + w, cpu + c
        g = mismatch(sol, arcs, arc_set.scale)[lead]       # a hand-off's two junctions: one root (.arc_handoffs)
        if not probe and before is not None and np.abs(g).max() > GROWTH * np.abs(before[1]).max() and halved < HALVINGS:
            # A secant step that made the mismatch grow: halved, from the last point kept (warm from its solution).
            # Near a junction the imposed NLP can have a second optimum that uses the bound dropped next to it (the
            # newcomer cart-pole's hinge force, 30-60% over its bound there, objective 378.2 for the problem's 399.6:
            # scripts/junction_branches.py); the full step fell into it and the secant wandered, 1e-5 never met.
            times, halved = (times + before[0]) / 2.0, halved + 1
            continue
        halved = 0
        if before is not None:
            old_times, old_g = before
            moved = (g != old_g) & (times != old_times)
            slopes = np.where(moved, (g - old_g) / np.where(moved, times - old_times, 1.0),
                              np.nan if slopes is None else slopes)
            slopes = None if np.any(np.isnan(slopes)) else tuple(float(x) for x in slopes)
        offset = state_offset(g, slopes, junctions, arcs, sol)
        # A state's junctions kept where they were given (a companion at its solution's junction times) take one
        # Newton step on the known slopes all the same: sharing them, the two would differ by nothing there, and a
        # state's junction moves the motion after it to first order (the fourth newcomer's cart-pole, its touch
        # 1.2e-7 s off its root: the pole's speed 1.4e-6 rad/s off, 2.9x the estimate).
        if _placed(g, offset, sol, tol) and not (before is None and offset):
            return sol, wall, cpu, trial, ArcSet(tuple(arcs), arc_set.scale, slopes), True
        known = slopes is not None and np.all(np.asarray(slopes, float) != 0.0)
        if before is None and known:
            # The slopes that placed the previous mesh's junctions: a Newton step, where a probe of FIRST_STEP of an
            # interval could land in the second optimum that the growth check guards against (the cart-pole's
            # companion at 1e-5: a probe of 0.0011 of the horizon, and IPOPT stayed in that optimum from there).
            new = times - g / np.asarray(slopes, float)
        elif before is None:
            # An arc's end later, or its start earlier, where the free side is past its bound there.
            sign = np.array([1.0 if side == "end" else -1.0 for _, side, _ in junctions])[lead]
            upper = np.array([1.0 if arcs[k].value == _bounds(first, arcs[k])[1] else -1.0 for k, _, _ in junctions])[lead]
            new = times + step * sign * np.sign(g) * upper
        else:
            old_times, old_g = before
            moved = g != old_g
            new = np.where(moved, times - g * (times - old_times) / np.where(moved, g - old_g, 1.0), times)
        probe = before is None and not known      # a first step that only probes the slope: its growth says nothing
        if best is None or np.abs(g).max() < best[0]:
            best = np.abs(g).max(), sol
        # Warm from the point of the smallest mismatch yet: from one in the second optimum, IPOPT stays there.
        before, warm = (times, g), best[1]
        if not np.all(np.isfinite(new)):
            break
        times = _in_order(times, np.clip(new, 1e-6, 1.0 - 1e-6), [arcs[k].quantity for k, _, _ in junctions])
    return sol, wall, cpu, trial, ArcSet(tuple(arcs), arc_set.scale, slopes), False


def try_due(tried: dict, structure: tuple, score: float, spread: float) -> bool:
    """Whether an arc structure is to be tried at this estimate ``score`` and junction ``spread`` (fractions of the
    horizon), recording the try in ``tried`` (structure -> (estimate at its first try, None once the estimate's retry
    is spent; spread at its last try)): a new structure while fewer than :data:`TRIES` were tried; a tried one once
    where the estimate has fallen by :data:`RETRY_DROP` since its first try, and each time the spread has fallen by
    :data:`RETRY_SHARPER` since its last."""
    if structure in tried:
        first_score, spread_then = tried[structure]
        if first_score is not None and score <= RETRY_DROP * first_score:
            tried[structure] = (None, spread)
        elif spread <= RETRY_SHARPER * spread_then:
            tried[structure] = (first_score, spread)
        else:
            return False
        return True
    if len(tried) >= TRIES:
        return False
    tried[structure] = (score, spread)
    return True


def align_junctions(problem, scheme, solution, tol: float, options: dict, progress, first, fallback, scale_objective,
                    tried: dict, score: float = np.inf):
    """The first imposition of ``solution``'s arcs (:func:`solve_on_arcs` from their located junctions):
    ``(solution, wall s, CPU s, mesh, arc_set)``, or None where there is no inner junction, a step is not solved, the
    steps do not converge or the arcs are not found to hold (module notes). ``tried``: the arc structures tried before
    (quantity, value, inner start, inner end of each arc), which are tried again and when: :func:`try_due`. A
    finer mesh can show an arc the first did not (a rod whose torque sits on its bound for the first 0.5% of the
    horizon: no collocation point of the first mesh falls there)."""
    arcs, scale = find_arcs(solution)
    jumps = not arcs and solution.transcription.layout.n_phases == 0     # else a bang-bang input's (.jump_arcs)
    if jumps:
        arcs, scale = find_jumps(solution)
    structure = tuple((a.quantity, a.value, a.start > 0.0, a.end < 1.0, is_touch(a)) for a in arcs)
    if not (inner := inner_junctions(arcs)):
        return None
    spread = max(_gap_around(solution.transcription.fractions, at) for _, _, at in inner)
    if not try_due(tried, structure, score, spread):
        return None
    # Each step's IPOPT capped in CPU (unless the options cap it): an imposed NLP whose arcs fix one another can be
    # singular, and MUMPS then spends minutes per solve to fail (the least-time crane at 1e-4: a step of 52 intervals,
    # 'Infeasible_Problem_Detected' after 166 s of CPU, where the whole refinement takes 12).
    # And a step IPOPT does not solve is not solved again with the fallback options: it ends the try.
    options = {"ipopt.max_cpu_time": max(MIN_CAP_S, CAP_FACTOR * float(sum(solution.wall_time.values()))), **options}
    try:
        sol, wall, cpu, mesh, arc_set, converged = solve_on_arcs(problem, scheme, ArcSet(tuple(arcs), scale, jumps=jumps),
                                                                 tol, options, solution, progress, first, None,
                                                                 scale_objective)
    except (OCPSolveError, ModelError):     # ModelError: a model that reads the time takes no free mesh point
        return None
    return (sol, wall, cpu, mesh, arc_set) if converged and holds(sol, arc_set.arcs, scale, tol) else None
