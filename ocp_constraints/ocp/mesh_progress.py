"""When mesh refinement has stopped paying: the stall rule of :func:`~.mesh_refinement.solve_to_tolerance`.

Where the solution is smooth, halving an interval of degree ``p`` divides its error by about
``2^(p+1)`` (16 at degree 3, 256 at degree 7; Patterson & Rao 2014), and raising the degree
divides it geometrically; even at a kink, halving divides it by 2-4. So a refinement that makes
the mesh much larger should cut the estimate by at least as much as it multiplied the points. When
it does not, the solution and its companion are not converging together (a singular or
non-unique arc, a path constraint's junction the mesh cannot resolve, a local optimum that moves
with the mesh), and every further refinement costs more than the last for little gain: the
four-bar of the suite at 1e-4 went 883 -> 1,709 points for an estimate 1.5e-2 -> 1.1e-2, then
3,361 points and about 550 s of CPU for 2.3e-2; it stops there now, where before this rule it went on
for as long as ``max_refinements`` (10) let it.

Refinement stops at the second such refinement, or at the first that made no progress at all (one
that made some can be the mesh moving to a switch), or after a run of smaller steps, each no lower in its
estimate than the one before, that together grew the points :data:`STALL_GROWTH` times
(:func:`_plateau_message`). It never judges the first refinement (the first mesh is coarse, its estimate
pre-asymptotic), nor, one by one, refinements that grew the mesh by less than :data:`STALL_GROWTH`: the small steps of a refinement that splits a few intervals at switches (the
walker, the minimum-time swing-up, 1.02-1.25x the points) may leave the estimate flat for a step
and then meet the tolerance.
"""
from __future__ import annotations

import time

from ..errors import OCPSolveError
from .nonsmooth import flag_nonsmooth, unflagged

STALL_GROWTH = 1.5      # a refinement that multiplied the points by at least this is judged by the rule
# An earlier solution is returned instead of the last only where its estimate is lower by more than this factor: the
# estimate is twice a difference (error_estimate.SAFETY) and true errors lie at 0.4-1 of it, so two estimates within
# this factor do not rank the solutions, and the last is on the finer mesh (lowest_estimate).
RANKED = 2.0
# A refinement stopped by a mesh IPOPT did not solve while its only estimate, the first mesh's, was over this many times
# the tolerance (or none was made) has not resolved the motion: it starts again from that mesh, solved from the
# problem's guess (restarted). Not later: a mesh refined several times is large, and a cold solve of it costly.
UNRESOLVED = 100.0
# What a stopped refinement returns (lowest_estimate), said where it stops.
RETURNED = (f"Returned: the last solution, or an earlier one whose estimate was more than {RANKED:g}x lower (then named "
            f"at the end of this message)")


def _largest(entry: dict, quantities) -> float:
    return max(float(entry["estimate"][q]) for q in quantities)


def _stalls(history: list[dict], quantities) -> list[tuple[int, float, float, bool]]:
    """The stalled refinements after the first: ``(index, growth, fall, no_progress)`` for each that grew the
    points by ``growth >= STALL_GROWTH`` and divided the largest estimate by ``fall < growth``;
    ``no_progress``: its estimate is no lower than the lowest one before it."""
    out = []
    for k in range(2, len(history)):
        prev, cur = history[k - 1], history[k]
        if not (prev.get("resolved", True) and cur.get("resolved", True)) or "estimate" not in prev or "estimate" not in cur:
            continue
        growth = cur["points"] / prev["points"]
        before, after = _largest(prev, quantities), _largest(cur, quantities)
        fall = before / after if after > 0 else float("inf")
        if growth >= STALL_GROWTH and fall < growth:
            lowest = min(_largest(e, quantities) for e in history[1:k] if "estimate" in e)
            out.append((k, growth, fall, after >= lowest))
    return out


def _where(entry: dict, quantities) -> str:
    """Which named quantity differs most from the companion, per gated quantity (``entry["worst"]``)."""
    worst = entry.get("worst", {})
    return ", ".join(f"{q}: {worst[q]}" for q in quantities if q in worst)


def _rising_run(history: list[dict], quantities) -> tuple[int, int]:
    """The refinements at the end of ``history`` since its lowest largest estimate (resolved ones with estimates,
    the first refinement not judged): ``(base, length)``, ``base`` the entry of that lowest estimate, ``length``
    the refinements after it, none lower (:func:`_plateau_message` also asks that the last step did not fall 2x).
    Not "each no lower than the one before": the rolling-disk drive at 1e-4
    reached 1.0e-4 on 155 points, then 4.5e-4, 6.2e-4, 9.8e-4, 9.6e-4 (the last a hair lower than the one before
    it, so that run restarted) and spent 27 s of CPU on a fifth mesh at 1.5e-2."""
    judged = [k for k in range(1, len(history)) if "estimate" in history[k] and history[k].get("resolved", True)]
    if not judged or judged[-1] != len(history) - 1:
        return len(history) - 1, 0
    base = min(judged, key=lambda k: (_largest(history[k], quantities), -k))
    after = [k for k in judged if k > base]
    if after != list(range(base + 1, len(history))):     # an unresolved or unestimated refinement inside the run
        return len(history) - 1, 0
    return base, len(history) - 1 - base


def _plateau_message(history: list[dict], tol: float, quantities) -> str | None:
    """Small steps that together grew the mesh :data:`STALL_GROWTH` times or more, none lowering the estimate
    below the lowest reached (:func:`_rising_run`), while it is above ``tol``: the rule above judges only steps that grew
    the points 1.5x each, and a refinement that keeps halving a few intervals at a kink no bound locates grows
    them 1.1-1.4x a step (the newcomer crane at 1e-5: 2,157 -> 2,612 -> 3,529 points, the multipliers' estimate
    3.9e-4 -> 5.6e-4 -> 5.7e-4, then 5,377 points and more than 200 s of CPU for the next two solves)."""
    base, length = _rising_run(history, quantities)
    cur = history[-1]
    if length < 2 or _largest(cur, quantities) <= tol:
        return None
    # Still falling (at least 2x on the last step, a halving's fall at first order) is going on: the newcomer
    # slider-crank at 1e-3 went 1.9e-3 -> 2.8e-2 -> 6.4e-3 -> 1.3e-3 and was met on the next mesh.
    if _largest(history[-2], quantities) >= 2.0 * _largest(cur, quantities):
        return None
    growth = cur["points"] / history[base]["points"]
    if growth < STALL_GROWTH:
        return None
    return (f"refinement stalled: the last {length} refinements grew the mesh {growth:.1f}x ({history[base]['points']} -> "
            f"{cur['points']} points) and none lowered the estimate ({_largest(history[base], quantities):.1e} -> "
            f"{_largest(cur, quantities):.1e}); the solution and its companion do not converge together here (largest "
            f"differences: {_where(cur, quantities)}), so more points are unlikely to reach {tol:.0e}. {RETURNED}: accept "
            f"a larger tolerance, or look for a path constraint's junction or a kink inside an interval (this message "
            f"lists the rough or non-smooth intervals where any were found)" + _zero_objective(cur))


def stall_message(history: list[dict], tol: float, quantities=("states", "multipliers")) -> str | None:
    """Why refinement should stop now, or ``None`` to go on.

    ``history``: the refinement's entries so far (each with ``points``, ``estimate`` per quantity and
    ``resolved``), the last one just estimated. A refinement (not the first) *stalls* when it multiplied
    the points by ``growth >= STALL_GROWTH`` and divided the largest estimate of ``quantities`` by less
    than ``growth``. Refinement stops at the second stall, or at the first that made no progress at all
    (its estimate no lower than one reached before). One stall that made progress is not enough: while
    the mesh moves to a switch a refinement can stall and the next converge (the suite's rolling disk at
    1e-3: 71 -> 141 points for an estimate 1.8x lower, then 239 points 6.2x lower, met at 246). Measured
    cases the rule was checked on: ``tests/test_mesh_progress.py``.
    """
    stalls = _stalls(history, quantities)
    if not stalls or stalls[-1][0] != len(history) - 1 or not (len(stalls) >= 2 or stalls[-1][3]):
        return _plateau_message(history, tol, quantities)
    _, growth, fall, _ = stalls[-1]
    prev, cur = history[-2], history[-1]
    where = _where(cur, quantities)
    best = min(_largest(e, quantities) for e in history[1:] if "estimate" in e)
    why = (f"the {len(stalls)} refinements that grew the points {STALL_GROWTH:g}x or more and cut the estimate by "
           f"less" if len(stalls) >= 2 else "it is no lower than one reached before")
    change = f"cut the estimate only {fall:.2g}x" if fall >= 1.0 else f"raised the estimate {1.0 / fall:.2g}x"
    return (f"refinement stalled: the last refinement grew the mesh {growth:.1f}x ({prev['points']} -> {cur['points']} "
            f"points) and {change} ({_largest(prev, quantities):.1e} -> {_largest(cur, quantities):.1e}; {why}), "
            f"where a converging solution's falls faster than its points grow; the solution and its companion do not "
            f"converge together here (largest differences: {where}), so more points would cost more than the last and "
            f"are unlikely to reach {tol:.0e} (the lowest estimate reached: {best:.1e}). {RETURNED}: accept a larger "
            f"tolerance, or look for a singular or non-unique arc, a path constraint's junction or a local optimum that "
            f"moves with the mesh" + _zero_objective(cur))


def _zero_objective(entry: dict) -> str:
    """A hint where the objective vanishes at the solution (a target that a terminal term alone asks for, reached
    exactly): every motion that reaches it is optimal, so the solution is not unique and no mesh converges to one."""
    J = entry.get("objective")
    if J is None or not abs(J) < 1e-12:
        return ""
    return (f"; here the objective is {J:.1e} at the solution: every motion that reaches it is optimal, so the solution "
            f"is not unique (add a term that picks one, e.g. minimize_effort)")


def interrupted(record: dict, refinement: int, latest):
    """Ctrl-C outside IPOPT (building or compiling a mesh's NLP; IPOPT stops itself at its next iteration and
    raises with its last iterate): the :class:`~ocp_constraints.errors.OCPSolveError` that keeps ``latest``, the
    last complete solution (None before the first), with the refinement's record saying where it stopped."""
    record["message"] = (f"interrupted during refinement {refinement}, outside IPOPT (building or compiling a mesh's "
                         "NLP); " + ("the last complete solution is kept in .solution" if latest is not None
                                     else "no mesh was solved yet"))
    if latest is not None:
        latest.mesh_refinement = record
    return OCPSolveError(record["message"], latest)


def gave_up(record: dict, refinement: int, exc: OCPSolveError, previous) -> str:
    """The message of a refinement stopped because IPOPT did not solve one of its meshes (``exc``, its status
    and iterations; the warm attempt and the retry with IPOPT's own options both failed) while ``previous``,
    the last solution whose error was estimated, is at hand: that solution is returned, "met" False."""
    scheme = previous.transcription.scheme
    said = str(exc).split("; the last iterate")[0]
    est, tol = record["estimate"], record["tolerance"]
    worst = max(est["states"], est["multipliers"])
    above = " above the tolerance" if worst > tol else ""
    # Far from the tolerance, the mesh does not resolve the motion, and a finer one warm-started from it may have
    # another optimum (a swing-up over 20 s from 10 intervals: estimate 14, the next mesh not solved in 280
    # iterations; from 40 intervals met at 1e-4): a finer start is the advice that works.
    advice = (f"start from a finer mesh, e.g. solve(oc.Radau({4 * scheme.intervals}, degree=5), tolerance=...) "
              f"(--intervals, --degree): this one does not resolve the motion" if worst > UNRESOLVED * tol else
              "accept a larger tolerance")
    return (f"stopped at refinement {refinement}: {said}, also with IPOPT's own options. Returned: the solution of "
            f"refinement {refinement - 1} ({scheme.intervals} intervals, {scheme.point_count} points) with its estimate "
            f"(states {est['states']:.1e}, multipliers {est['multipliers']:.1e}){above}; {advice}, or "
            f"pass more IPOPT iterations ('ipopt.max_iter') to solve the next mesh")


def unestimated(record: dict, entry: dict, exc: OCPSolveError, first) -> str:
    """The message of a refinement whose first mesh solved (``first``, its history ``entry``) but whose companion, the
    solve its error is estimated against, did not (``exc``; the warm attempt and the retry both failed): ``first`` is
    returned, "met" False, ``record["estimate"]`` None (not estimated). Before, ``solve`` raised the companion's
    :class:`OCPSolveError`, whose ``.solution`` was the companion's last iterate, not the solved first mesh, and where a
    looser tolerance (another companion) returned "not met" (a seventh newcomer's URDF arm from the default first mesh:
    an exception at 1e-4..1e-6, "not met" at 1e-3; results/bench/refinement_newcomer7.md)."""
    scheme = first.transcription.scheme
    said = str(exc).split("; the last iterate")[0]
    entry["solves"] = 1         # the first mesh's; the companion's attempt is entry["failed"]
    record.update(mesh=entry["mesh"], degrees=entry["degrees"], estimate=None, refinements=0,
                  total_time_s=entry["time_s"], total_cpu_s=entry["cpu_s"])
    return (f"stopped at refinement 0: the first mesh ({scheme.intervals} intervals, {scheme.point_count} points) solved, "
            f"but its companion, the solve its error is estimated against, did not: {said}, also with IPOPT's own "
            f"options. Returned: the first mesh's solution, its error NOT estimated ('estimate' None). A companion that "
            f"does not solve from the first solution often means the first mesh is too coarse for the motion (its optimum "
            f"is not the finer mesh's): start from a finer mesh (solve(oc.Radau(40, degree=3), tolerance=...); "
            f"--intervals, --degree), or pass more IPOPT iterations ('ipopt.max_iter')")


def unresolved(record: dict | None, tol: float) -> bool:
    """Whether a refinement stopped by a mesh not solved is far from resolving the motion: no estimate yet (``record``
    None), or the first mesh's alone and over :data:`UNRESOLVED` times ``tol`` (then :func:`restarted`)."""
    return record is None or (record["refinements"] == 0 and
                              max(record["estimate"]["states"], record["estimate"]["multipliers"]) > UNRESOLVED * tol)


def restarted(first, clock: tuple, solve_starts, refine_from):
    """A refinement stopped by a mesh IPOPT did not solve warm while its motion was not resolved (:func:`unresolved`;
    ``first`` returned, by :func:`unestimated` or :func:`gave_up`), started again from the problem's guess: a
    multi-start (``solve_starts()``: :func:`.multistart.solve_multistart` on the first mesh at a low degree, the
    problem's guess and perturbed ones, the best kept; its solution, wall and CPU seconds), and the refinement
    continued from its best (``refine_from(those)``). A mesh too coarse for the motion has an optimum of its own, which
    misleads the finer mesh's warm solve; and a single cold start of a nonconvex problem lands in an optimum that
    depends on the mesh and on the machine's floating point. A seventh newcomer's URDF arm: Radau 5 x 10 reaches
    J = 28.87 with link 2 spinning at 37 rad/s, and its pilot, Radau 7 x 20, warm from it, is not solved; from the
    problem's guess alone, Radau 7 x 20 solved in 20 iterations to J = 9.074 on one machine and not in 3,000 on
    another, Radau 3 x 20 reached 9.074 and the same mesh 1e-16 apart 97.6; eight starts on Radau 3 x 20 reach
    7.163, 9.074 (five), 13.3 and 31.3, and the best is refined to 7.1646. ``clock``: (wall, CPU) at the refinement's
    start, every attempt counted. Where no start is solved, ``first`` is returned with its message saying so."""
    earlier = first.mesh_refinement
    scheme = first.transcription.scheme
    try:
        started = solve_starts()
    except OCPSolveError as exc:
        if exc.solution is not None and exc.solution.status.startswith("interrupted"):
            raise
        earlier["message"] += (". Started again from the problem's guess and perturbed ones: none solved ("
                               + str(exc).split("; start 0's last iterate")[0] + ")")
        earlier.update(total_time_s=time.perf_counter() - clock[0], total_cpu_s=time.process_time() - clock[1])
        return first
    best = started[0]
    mesh, summary = best.transcription.scheme, best.multistart
    sol = refine_from(started)
    record = sol.mesh_refinement
    record.pop("finer_start", None)
    record["restarted"] = {
        "solution": {"intervals": scheme.intervals, "points": scheme.point_count, "objective": float(first.objective)},
        "history": earlier["history"], "message": earlier["message"], "multistart": summary}
    optima = ", ".join(f"{o['objective']:.6g}" + (f" ({o['count']})" if o["count"] > 1 else "") for o in summary["optima"])
    record["message"] += (f" (started again: the first solution ({scheme.intervals} intervals, objective "
                          f"{float(first.objective):.6g}) did not resolve the motion and the finer mesh did not solve "
                          f"from it; {summary['succeeded']} of {summary['starts']} starts from the problem's guess and "
                          f"perturbed ones on {mesh.intervals} intervals, {mesh.point_count} points, reached {optima}, "
                          f"the lowest refined; 'restarted' has the first attempt)")
    record.update(total_time_s=time.perf_counter() - clock[0], total_cpu_s=time.process_time() - clock[1])
    return sol


def lowest_estimate(record: dict, last, last_score: float, best: tuple, tol: float):
    """The solution to return from a refinement that ends "not met": ``last`` (the last solution whose error was
    estimated, its largest gated estimate ``last_score``), or, where an earlier one had a lower estimate (``best``: its largest gated estimate, the solution,
    its mesh and estimate, its smoothness and jump windows), that one, with ``record`` made to describe it (its
    jump windows and untrusted intervals, :func:`.nonsmooth.flag_nonsmooth`; the last mesh's under ``last_mesh``)
    and its message saying so. A refinement that stalls or runs out of refinements often ends on a mesh whose
    estimate has risen (a newcomer's rod at 1e-4: 3.5e-4 on its best mesh, 1.4e-3 on its last), and the user asked
    for the smallest error. ``met``: ``last``. Only lower by more than :data:`RANKED`: a sixth newcomer's steep tracking
    pendulum at 1e-3 stalled with estimates 0.171 on its second mesh and 0.173 on its third, and the second, another
    local optimum (objective +0.17%, its multipliers 1.46x the estimate), was returned where the third was on the
    right one."""
    score, sol, described, smoothness, windows = best
    if record["met"] or sol is None or sol is last or not RANKED * score < last_score:
        return last
    was = record["estimate"]
    for key in ("jump_windows", "nonsmooth_intervals", "rough_intervals"):    # found on the last mesh, not this one
        if key in record:
            record.setdefault("last_mesh", {})[key] = record.pop(key)
    record.update({k: v for k, v in described.items() if k != "refinements"})    # "refinements": how many were made
    record["returned_refinement"] = described["refinements"]
    # The last mesh's jump windows and untrusted intervals are under "last_mesh"; the message tells the returned one's.
    record["message"] = (unflagged(record.get("message", "")) + f"; returned: the solution of refinement {described['refinements']} "
                         f"({len(described['degrees'])} intervals), the lowest estimate seen (states "
                         f"{described['estimate']['states']:.1e}, multipliers {described['estimate']['multipliers']:.1e}; "
                         f"the last mesh's: {was['states']:.1e}, {was['multipliers']:.1e})")
    flag_nonsmooth(sol, tol, record, smoothness, windows)
    return sol


def more_refinements(history: list[dict], quantities) -> str:
    """The advice of a refinement out of refinements: more of them, unless the last refinements raised the estimate
    (its largest gated value over 2x the lower of the two before; a tenth newcomer's least-time swing under a
    hinge-force bound at 1e-6 went 2.8e-5 -> 6.8e-4 over its last refinements and was told to raise max_refinements)."""
    scores = [_largest(h, quantities) for h in history if h.get("estimate")]
    if len(scores) >= 3 and scores[-1] > 2.0 * min(scores[-3:-1]):
        return (f"the last refinements raised the estimate ({min(scores[-3:-1]):.1e} -> {scores[-1]:.1e}), so more of "
                f"them are unlikely to lower it: accept a larger tolerance")
    return "raise max_refinements (solve(..., max_refinements=N), --max-refinements N) or accept a larger tolerance"


def inputs_aside(totals: dict, tol: float) -> str:
    """What a "met" message adds where the inputs' estimate is above ``tol``: "met" is decided on the states and
    multipliers (:data:`.mesh_refinement.GATED`, issue 19); the inputs are reported, not refined on. A newcomer's pendulum over 3 s
    read "estimated error at most 0.0001" with its torque's estimate 4.3e-4 and true error 2.1e-4."""
    inputs = totals.get("inputs", 0.0)
    if inputs <= tol:
        return ""
    return (f" for the states and multipliers; the inputs' estimate is {inputs:.1e} (relative to the largest input): "
            f"they are reported, not refined on; ask a smaller tolerance where the inputs must meet this one")


# Objectives of successive meshes further apart than this (relative) are two local optima, not one refined.
OPTIMUM_CHANGE = 0.01


def optimum_changed(record: dict) -> None:
    """Say so in ``record`` where the returned solution's objective is not the earlier meshes' (more than
    :data:`OPTIMUM_CHANGE` apart): a mesh's warm solve left the optimum the refinement had followed for another one, and
    the estimate is of the new one alone (a thirteenth newcomer's five-bar at 1e-7: J = 6.8162557 on seven meshes, then
    0.8403 on the last, "met" with nothing said; the new optimum is genuine, its error honest against its own reference).
    ``"optimum_changed"``: the objectives before and after, and the refinement where it changed."""
    history = [h for h in record.get("history", []) if h.get("objective") is not None]
    returned = record.get("returned_refinement", history[-1]["refinement"] if history else None)
    upto = [h for h in history if h["refinement"] <= returned] if returned is not None else []
    if len(upto) < 2:
        return
    before, after = float(upto[-2]["objective"]), float(upto[-1]["objective"])
    if abs(after - before) <= OPTIMUM_CHANGE * max(abs(before), abs(after)):
        return
    record["optimum_changed"] = {"objective_before": before, "objective": after, "refinement": upto[-1]["refinement"]}
    record["message"] += (f"; note: refinement {upto[-1]['refinement']} reached another local optimum (objective "
                          f"{before:.8g} on the mesh before, {after:.8g} now): the estimate is of this one; the earlier "
                          f"meshes followed the other (start from a finer mesh or another guess to compare them)")
