"""Accuracy on request: hp mesh refinement to a tolerance (issue 19).

``problem.solve(tolerance=1e-6)`` starts from a coarse Radau mesh and repeats:

1. solve on the current mesh (warm-started from the previous refinement's companion; a warm solve that its start
   misleads is stopped and solved again with IPOPT's own options, :data:`WARM_FACTOR`, that retry capped too,
   :data:`FALLBACK_FACTOR`; a mesh neither solves ends the refinement with the last estimated solution); at a
   tolerance of 1e-4 or below, where the first solution reaches a bound or a path constraint, the warm solves hold
   IPOPT's complementarity to 1e-14 (:func:`.mesh_solves.complementarity_tolerance`: the barrier rounds the corners
   there by more the shorter the intervals), with MUMPS's scaling off (:func:`.mesh_solves.without_mumps_scaling`),
   and the first mesh is solved again so, warm from its cold solution (:func:`.mesh_solves.tightened`); from the
   first resolved estimate on, the warm solves scale the objective to a curvature of 1 (:mod:`.objective_scaling`);
2. judge it against a *companion*: a solution at hand that is finer everywhere, if there is one
   (:func:`.mesh_companions.finer`: each interval halved at a degree at least its own, or kept at two
   degrees more; no solve; none where a junction lies inside an interval), else the same mesh with every degree
   raised by two and the intervals holding a located junction halved (:func:`.mesh_companions.companion_of`),
   solved warm from 1 (on the first mesh: the *pilot*, every interval halved at :data:`MAX_DEGREE`, or cut finer where the
   first solution's own Legendre coefficients predict that a halving will not do, :func:`pilot_of`, ``pilot_pieces``);
   the estimate of each interval's error is :data:`.error_estimate.SAFETY` times their difference
   (:mod:`.error_estimate`). Where the next mesh asks for no more than the pilot has and the pilot is
   not much larger (:func:`.mesh_companions.as_fine`, :data:`SNAP_POINTS`), the pilot is the next mesh, one solve fewer;
3. *switches*: where an input bound or a path constraint jumps between its bounds inside an interval
   (read from the NLP's solution, :mod:`.switch_detection`), the interval is split *at* the located
   switch time, whatever its estimate, and the inputs' and multipliers' estimates leave out the
   intervals the jump touches (their error there is the jump itself on any mesh, short of a switch
   time that is a variable); the states' estimate is at least the switch's own effect;
4. stop when the estimate of the states (absolute, SI units) and of the multipliers (relative
   to the largest load) is at most ``tolerance`` and no switch is left inside an interval; else
   refine every interval whose share of the estimate exceeds it (the states' and multipliers' share: the part
   of their difference from the companion made there, not an error made elsewhere and carried along,
   :meth:`.error_estimate.ErrorEstimate.refinement_ratio`), an hp rule after Patterson, Hager and Rao (2014)
   (:func:`.hp_rule.refine`): a smooth interval gets the degree that a fall of the error of about 4x per
   degree predicts, up to :data:`MAX_DEGREE`, else it is split at that degree into as many pieces as
   the rest of the error needs; an interval refined last time whose estimate fell less than tenfold
   *and* whose inputs or multipliers are not smooth (:func:`.legendre_decay.legendre_decay`) is
   *rough* (a kink no bound located) and is halved at :data:`MIN_DEGREE`, down to :data:`ROUGH_MIN`
   of the horizon (a smooth interval whose estimate fell too slowly is still short of resolution:
   dropping its degree to 3 made the four-bar and the acrobot hundreds of intervals);
   *guard*: where the companion differs from the solution by more than a mesh error can be (the
   objectives by more than 2%, a state by more than a quarter of its range, :func:`.error_estimate.resolution`),
   the two are not one optimum seen at two resolutions, and the per-interval estimate says nothing:
   the next mesh is then the companion's, every interval halved (:func:`uniform_step`), warm-started
   from the companion, no interval judged rough from it, and "met" is not claimed on it;
5. when the estimate meets the tolerance but an interval's inputs or multipliers are still not smooth
   (no bound located a switch there), that interval is halved and the refinement goes on
   (:func:`.nonsmooth.nonsmooth_splits`); on the last refinement such intervals withdraw "met" and are named
   (:func:`.nonsmooth.flag_nonsmooth`): there the companion is no upper bound;
6. where an input with an effort term (or a path constraint moving with such inputs) rides its bound and the estimate
   is resolved but not met: its arcs imposed and their junctions made mesh points at the roots of its continuity
   mismatch (:mod:`.junction_times`; each arc structure tried once, and again where the estimate has fallen 10x);
   where there is none but an input that no effort term holds is bang-bang, its arcs imposed and each jump a mesh
   point whose time is an NLP variable (:mod:`.jump_arcs`, :mod:`.free_mesh_points`);
7. stop ("met" not claimed) when more points no longer pay: a second stall, one with no progress, or a run of small
   steps that never lowered the estimate (:mod:`.mesh_progress`); a refinement that ends "not met" returns the
   solution with the lowest estimate it saw (:func:`.mesh_progress.lowest_estimate`), not always its last.

Every mesh is transcribed in the problem's own coordinates (joint coordinates under the default
``coordinates="auto"`` where they apply); the estimate reads states and multipliers by name.

The solution returned is step 1's on the last mesh (its error is what the estimate
estimates; "not met": on the mesh of the lowest estimate, ``returned_refinement``); ``sol.mesh_refinement`` holds the final mesh and degrees, the estimate per
quantity, and the history (mesh, solves, IPOPT iterations and times of each refinement, the
companion it was judged against, the switches located).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import ModelError, OCPSolveError
from .bound_overshoot import name_overshoots
from .error_estimate import UNRESOLVED_OBJECTIVE, UNRESOLVED_STATE, estimate_error
from .hp_rule import MIN_DEGREE, ROUGH_MIN, refine  # noqa: F401 (MIN_DEGREE, ROUGH_MIN: read here by tests and docs)
from .junction_times import align_junctions, described, solve_on_arcs
from .legendre_decay import DECAY_LIMIT, legendre_decay
from .mesh_companions import (MAX_DEGREE, _degrees, _ends, as_fine, companion_of, finer, finer_at_hand, low_degree, pilot_of,
                              pilot_pieces, uniform_step)
from .mesh_progress import (gave_up, inputs_aside, interrupted, lowest_estimate, more_refinements, optimum_changed, restarted,
                            stall_message,
                            unestimated, unresolved)
from .multistart import solve_multistart
from .mesh_solves import check_max_refinements  # noqa: F401 (problem.solve reads it here)
from .mesh_solves import (COMPLEMENTARITY, MUMPS_SCALING, check_solver_tolerances, check_tolerance, complementarity_tolerance,
                          solver_floor, tightened, without_mumps_scaling, iterations as _iterations,
                          timed_solve as _timed_solve)
from .nonsmooth import MIN_INTERVAL, flag_nonsmooth, judged_smoothness, nonsmooth_splits
from .schemes import Radau
from .switch_detection import detect_switches, jump_windows, record_switches, split_points, touched
from .time_breakpoints import with_breakpoints

MAX_REFINEMENTS = 10
# The pilot replaces the next mesh (one solve fewer) only if it has at most this many times its points (its companion
# and the solution returned are then that much larger; where solve time grows like the points, the saved solve pays for
# ~1.8x): 1.5 keeps a margin, and a non-smooth solution (short intervals at a switch) is not traded for a finer mesh.
SNAP_POINTS = 1.5
GATED = ("states", "multipliers")
# The first mesh. Degree 5 rather than 3 (scripts/refinement_robustness.py, results/bench/refinement_start.md): at
# 1e-3 the 21 problems met both ways end on as few points or fewer on 18 (7,053 points against 8,861) for 29% less
# CPU; at 1e-5, on 11 of 12, for 24% more CPU (the ball-and-socket reach and the quadrotor); on degree 3 the first
# solutions of four (the spherical pendulums, a slider-crank, a cart-pole) were too coarse for their pilots to
# confirm them, and the unresolved comparison doubled their meshes (281 points where 51-155 do).
START = {"intervals": 10, "degree": 5}
# A warm start begins near its optimum. mu_init 1e-8 spares IPOPT driving the barrier down from 0.1 (swing-up 6 -> 3-4
# iterations; acrobot 219 -> 205 over a refinement; same meshes: python scripts/mesh_refinement_warm_mu.py --suite).
# bound_push / bound_frac 1e-9 (IPOPT: 1e-2) keep the start on its variables' bounds: along an arc on a state bound
# the default moved every point 0.01 off it (Bryson-Denham, examples/bryson_denham.py: 57-72 iterations per warm
# solve, 1e-5 not met in 400 s of CPU; now 9-14, met in 9.7 s). Path constraints' slacks keep IPOPT's 1e-2: at
# 1e-9 the wheel's friction cone took 104 IPOPT iterations for 60 (refinement_robustness.py --only newcomer:wheel).
WARM_IPOPT = {"ipopt.mu_init": 1e-8, "ipopt.bound_push": 1e-9, "ipopt.bound_frac": 1e-9,
              "ipopt.slack_bound_push": 1e-2, "ipopt.slack_bound_frac": 1e-2}
AT_HAND = 3              # solutions kept as possible judges of later meshes
DESCRIBED = ("mesh", "degrees", "estimate", "worst", "load_scale")     # what the record says of the solution returned
# A warm solve that takes more IPOPT iterations than this many times the first mesh's cold solve (and at least
# WARM_MIN_ITER) has been misled by its start: WARM_IPOPT's small barrier parameter keeps IPOPT near the start's
# active set. It is stopped there and solved again from the same start with IPOPT's own (.mesh_solves.timed_solve).
# The suite's quadrotor from Radau 5 N = 10: its pilot took 149 iterations and 49 s of CPU to a worse optimum
# (J = 123.386) with WARM_IPOPT, 6 iterations to J = 123.253 without; a mesh 1e-16 apart took 4 with it.
WARM_FACTOR, WARM_MIN_ITER = 3, 30
# The retry with IPOPT's own options is capped too, at this many times the first mesh's cold iterations: the
# suite's four-bar at 1e-3 once spent 2,255 iterations and 771 s of CPU on one companion (the robustness notes,
# session 11). Past the cap the refinement stops and returns the last solution whose error was estimated.
FALLBACK_FACTOR, FALLBACK_MIN_ITER = 10, 100
# Starts of the restart's multi-start (mesh_progress.restarted), each capped as a retry: on the seventh newcomer's
# URDF arm eight starts on Radau 3 x 20 took 2 s of CPU and reached four optima, the lowest 7.163.
RESTART_STARTS = 8


def start_scheme(method, problem=None) -> Radau:
    """The first mesh: ``method`` if it is Radau, else :data:`START` (10 intervals of degree 5); given ``problem``, with a
    mesh point at each time its expressions kink or jump (:func:`.time_breakpoints.with_breakpoints`)."""
    method = Radau(START["intervals"], degree=START["degree"]) if method is None else method
    if not isinstance(method, Radau):
        raise ModelError(f"mesh refinement to a tolerance raises Radau degrees and splits Radau intervals; "
                         f"{getattr(method, 'label', repr(method))} has a fixed order: pass Radau(N, degree=d) as the starting mesh, or none")
    return method if problem is None else with_breakpoints(method, problem)


def _count(r: int) -> str:
    return f"{r} refinement" + ("" if r == 1 else "s")


def solve_to_tolerance(problem, tolerance, method=None, ipopt_options: dict | None = None, warm_start=None, *,
                       progress: bool | None = None, max_refinements: int = MAX_REFINEMENTS, started: tuple | None = None):
    """Solve ``problem`` with hp mesh refinement until the estimated error is at most ``tolerance``.

    Parameters
    ----------
    tolerance
        The error accepted: states (coordinates and speeds) absolute in SI units, multipliers
        (constraint forces and moments, eq. 26) relative to the largest load.
    method
        The starting mesh (a :class:`Radau`); default 10 intervals of degree 5.
    started
        (wall, CPU) seconds the total times count from (``problem.solve``: before its checks), else now.
    max_refinements
        Refinements after the first solve; if the estimate is still above the tolerance then, the
        last solution (or an earlier one of a much lower estimate) is returned, ``mesh_refinement["met"]`` False.

    Returns the :class:`~ocp_constraints.ocp.solution.OCPSolution` on the last mesh, ``mesh_refinement`` filled in
    (module notes). A mesh IPOPT does not solve (warm, then with its own options, capped) stops the refinement, "met"
    False, with the last estimated solution (:func:`.mesh_progress.gave_up`; the first mesh's, estimate None, where its
    companion failed: :func:`.mesh_progress.unestimated`), or, the motion not resolved, starts it again once from
    a multi-start on the first mesh at a low degree (:func:`.mesh_progress.restarted`). If the first mesh is not solved, or on Ctrl-C, :class:`OCPSolveError` is
    raised, its ``solution.mesh_refinement`` holding the history so far (:func:`.mesh_progress.interrupted`)."""
    clock = started or (time.perf_counter(), time.process_time())
    sol = _refine(problem, tolerance, method, ipopt_options, warm_start, progress, max_refinements, clock=clock)
    if sol.mesh_refinement.pop("finer_start", None) is None:     # the refinement did not stop unresolved
        return sol
    cap = max(FALLBACK_MIN_ITER, FALLBACK_FACTOR * sol.mesh_refinement["history"][0].get("iterations", 0))   # as a retry
    cold = {"ipopt.max_iter": cap, **(ipopt_options or {})}
    low = low_degree(start_scheme(method, problem))

    def solve_starts():
        wall, cpu = time.perf_counter(), time.process_time()
        best = solve_multistart(problem, low, RESTART_STARTS, 0, None, cold, None, check=False, progress=progress)
        return best, time.perf_counter() - wall, time.process_time() - cpu

    return restarted(sol, clock, solve_starts,
                     lambda started: _refine(problem, tolerance, low, ipopt_options, None, progress, max_refinements,
                                             clock=clock, solved_first=started))


def _refine(problem, tolerance, method, ipopt_options, warm_start, progress, max_refinements, first_cap=None, clock=None,
            solved_first=None):
    """The refinement loop of :func:`solve_to_tolerance` from one first mesh (``first_cap``: IPOPT's iterations on
    its first solve, where the options set none; ``clock``: (wall, CPU) the total times count from; ``solved_first``:
    the first mesh's solve already done, (solution, wall s, CPU s))."""
    tol = check_tolerance(tolerance)
    scheme, options = start_scheme(method, problem), dict(ipopt_options or {})
    options.update(without_mumps_scaling(options) if scheme != start_scheme(method) else {})   # see time_breakpoints
    check_solver_tolerances(options, tol)
    floor = solver_floor(options)       # no estimate below what each solve is asked of IPOPT (error_estimate)
    history: list[dict] = []
    record = {"tolerance": tol, "quantities_refined_on": list(GATED), "met": False, "history": history,
              "coordinates": problem.nlp_coordinates}
    parents, warm, first, solved, sol = None, warm_start, None, None, None
    clock = clock or (time.perf_counter(), time.process_time())
    pending = None      # the mesh being solved: a first mesh to start again from where it fails (mesh_progress.restarted)
    # Solutions solved lately: a finer one may judge a later mesh (:func:`finer`). Meshes grow, so a finer one is
    # among the last few; the older ones (each with its NLP and IPOPT instance) are let go.
    at_hand: list = []
    score, best = np.inf, (np.inf, None, None, None, ())   # the last estimated solution's largest gated estimate; the lowest
    warm_options = {**WARM_IPOPT, **options}    # capped once the first mesh's cold solve has said how hard it is
    fallback, previous, scale = options, None, False     # previous: the last solution whose error was estimated
    arcs, tried = None, {}        # arcs imposed (junction_times.ArcSet), the arc structures tried (their estimates)

    def warm_solve(mesh, start):    # -> solution, wall, CPU, its mesh (junctions moved where arcs are imposed), arcs
        if arcs:
            got, wall, cpu, mesh, moved, _ = solve_on_arcs(problem, mesh, arcs, tol, warm_options, start, progress, first,
                                                           fallback, scale)
            return got, wall, cpu, mesh, moved
        return (*_timed_solve(problem, mesh, warm_options, start, progress, first, fallback, scale), mesh, arcs)
    for r in range(max_refinements + 1):
        entry = {"refinement": r, "intervals": scheme.intervals, "points": scheme.point_count,
                 "mesh": [float(m) for m in scheme.mesh_fractions], "degrees": [int(d) for d in _degrees(scheme)]}
        history.append(entry)
        try:
            if solved is not None:      # this mesh is the last companion's (or the arcs' last step): its solution is at hand
                sol, t_sol, c_sol = solved, 0.0, 0.0
                entry["arcs_aligned" if "input_arcs" in history[-2] else "solved_as_companion"] = True
            elif r == 0 and solved_first is not None:
                sol, t_sol, c_sol = solved_first
            else:
                pending = scheme if r > 0 else None
                cold = {"ipopt.max_iter": first_cap, **options} if first_cap else options
                if warm is None:
                    sol, t_sol, c_sol = _timed_solve(problem, scheme, cold, None, progress, first)
                else:
                    sol, t_sol, c_sol, scheme, arcs = warm_solve(scheme, warm)
                    entry.update(mesh=[float(m) for m in scheme.mesh_fractions])
            if first is None:
                first = sol.transcription
                later = dict(options)    # the warm solves: IPOPT's complementarity held to the tolerance (mesh_solves)
                if (compl := complementarity_tolerance(tol, options, sol)) is not None:
                    later[COMPLEMENTARITY] = record["complementarity_tolerance"] = compl
                    later.update(without_mumps_scaling(options))     # MUMPS's scaling there: mesh_solves
                    record["mumps_scaling"] = later[MUMPS_SCALING]
                warm_options = {**WARM_IPOPT, "ipopt.max_iter": max(WARM_MIN_ITER, WARM_FACTOR * sol.iterations), **later}
                fallback = {"ipopt.max_iter": max(FALLBACK_MIN_ITER, FALLBACK_FACTOR * sol.iterations), **later}
                if compl is not None:       # the first mesh too, under the tightened complementarity (mesh_solves)
                    sol, t_more, c_more = tightened(sol, warm_options, progress)
                    t_sol, c_sol = t_sol + t_more, c_sol + c_more
            entry.update(iterations=0 if solved is not None else _iterations(sol), time_s=t_sol, cpu_s=c_sol,
                         objective=float(sol.objective), objective_scale=float(getattr(sol, "objective_scale", 1.0)))
            found = detect_switches(sol)        # bounds switching: jumps left out of the multipliers' estimate
            kinked = {w.interval for w in found if w.kind == "junction" and w.inside}
            judge = finer_at_hand(scheme, at_hand) if r > 0 and not kinked else None
            if solved is None:
                at_hand.append(sol)
            if judge is not None:   # a solution at hand is finer everywhere: it is the companion, no solve
                companion, t_comp, c_comp = judge, 0.0, 0.0
                entry["judged_against"] = {"intervals": judge.transcription.scheme.intervals,
                                           "points": judge.transcription.scheme.point_count}
            else:
                pending = pilot_of(scheme, pilot_pieces(sol, tol)) if r == 0 else companion_of(scheme, kinked)
                companion, t_comp, c_comp, _, _ = warm_solve(pending, sol)
                at_hand.append(companion)
            del at_hand[:-AT_HAND]
            entry["solves"] = (solved is None) + (judge is None)
        except OCPSolveError as exc:
            kept = previous if previous is not None else sol    # none estimated yet: the first mesh's, if it solved
            if kept is not None and exc.solution is not None and not exc.solution.status.startswith("interrupted"):
                entry["failed"], sol = str(exc), kept
                record["message"] = gave_up(record, r, exc, kept) if previous is not None else unestimated(record, entry, exc, kept)
                if pending is not None and unresolved(record if previous is not None else None, tol):
                    record["finer_start"] = pending
                break
            record["message"] = f"refinement {r}: {exc}"
            if exc.solution is not None:
                exc.solution.mesh_refinement = record
            raise
        except KeyboardInterrupt:               # a build or a compile: keep the last complete solution
            raise interrupted(record, r, sol) from None
        windows = jump_windows(found + detect_switches(companion), scheme.mesh_fractions)
        est = estimate_error(sol, companion, windows=windows, switches=found, floor=floor)
        scale = scale or est.resolved       # warm solves scale the objective from the first resolved mesh on
        if judge is None:
            entry.update(companion_iterations=_iterations(companion), companion_time_s=t_comp, companion_cpu_s=c_comp)
        retried = [dict(x.warm_retry, of=of) for x, of, new in ((sol, "solution", solved is None),
                                                               (companion, "companion", judge is None))
                   if new and hasattr(x, "warm_retry")]
        if retried:
            entry["warm_retries"] = retried
        entry.update(**est.as_dict())
        previous = sol
        score = max(est.totals[q] for q in GATED) if est.resolved else np.inf
        ratio = est.refinement_ratio(tol, GATED)      # where the error is made (ErrorEstimate.refinement_ratio)
        record.update(mesh=entry["mesh"], degrees=entry["degrees"], estimate=entry["estimate"], worst=entry["worst"],
                      load_scale=entry["load_scale"], refinements=r)
        if not est.resolved:
            # Guard: the two solutions are not one optimum at two resolutions (module notes, step 2).
            if r == max_refinements:
                record["message"] = (f"not resolved after {_count(r)}: the solution and its companion still "
                                     f"differ by {est.objective_change:.1e} in the objective and {est.state_change:.2f} "
                                     f"of a state's range (more than a mesh error can: {UNRESOLVED_OBJECTIVE:g}, "
                                     f"{UNRESOLVED_STATE:g}), so the estimate is not an error; raise max_refinements "
                                     f"(solve(..., max_refinements=N), --max-refinements N) or start from a finer "
                                     f"mesh")
                break
            new, parents, solved = uniform_step(companion.transcription.scheme), None, None
            scheme, warm = new, companion
            continue
        # Switches inside intervals (switch_detection): there the estimate is no bound; split at them.
        met = all(est.totals[q] <= tol for q in GATED)
        smoothness = judged_smoothness(legendre_decay(sol, companion), found)   # per interval, read thrice below
        if score < best[0]:
            best = (score, sol, dict(refinements=r, **{k: entry[k] for k in DESCRIBED}), smoothness, windows)
        switches = split_points(found, scheme.mesh_fractions, MIN_INTERVAL, tol, ratio) or (
            nonsmooth_splits(sol, tol, smoothness, windows) if met and r < max_refinements else {})
        entry["switches"] = [f for k in sorted(switches) for f in switches[k]]
        if met and not switches:
            record.update(met=True, message=f"estimated error at most {tol:g} after {_count(r)} "
                                            f"({scheme.intervals} intervals, {scheme.point_count} points)"
                                            + inputs_aside(est.totals, tol))
            flag_nonsmooth(sol, tol, record, smoothness, windows)
            break
        if r == max_refinements:
            record["message"] = (f"estimate still above {tol:g} after {_count(r)} (states "
                                 f"{est.totals['states']:.1e}, multipliers {est.totals['multipliers']:.1e}); "
                                 + more_refinements(history, GATED) + est.arc_note(tol))
            mesh = scheme.mesh_fractions
            record["rough_intervals"] = [[float(a), float(b)] for a, b, q in zip(mesh[:-1], mesh[1:], ratio)
                                         if q > 1.0 and (parents or {}).get(_ends(a, b), np.inf) < 10.0 * q]
            if record["rough_intervals"]:
                spots = ", ".join(f"{a:.6g}-{b:.6g}" for a, b in record["rough_intervals"][:4])
                record["message"] += (f"; the estimate stays above it on intervals that refinement does not improve "
                                      f"(a switch or a kink: inputs or multipliers jump or bend there), at fractions "
                                      f"{spots} of the horizon")
            flag_nonsmooth(sol, tol, record, smoothness, windows)
            break
        if arcs is None and est.resolved:       # arcs on a bound imposed (junction_times.align_junctions: which are tried)
            if (aligned := align_junctions(problem, scheme, sol, tol, warm_options, progress, first, fallback, scale,
                                           tried, score)):
                solved, _, entry["arcs_cpu_s"], scheme, arcs = aligned
                warm, parents, at_hand[:] = solved, None, [solved]
                entry["input_arcs"] = described(arcs.arcs, solved.t_final)
                continue
        if stalled := stall_message(history, tol, GATED) or est.held_by_arcs(tol, GATED):    # more points no longer pay
            record["message"] = stalled + est.arc_note(tol)
            flag_nonsmooth(sol, tol, record, smoothness, windows)
            break
        # Rough intervals (see refine): where the solution switches; a jump of the inputs and
        # multipliers there keeps their largest error near the jump's size at any mesh.
        mesh = scheme.mesh_fractions
        nonsmooth = (smoothness[0] > DECAY_LIMIT) & ~touched(found, mesh)   # not rough: a located switch
        rough = [[float(a), float(b)] for a, b, q, j in zip(mesh[:-1], mesh[1:], ratio, nonsmooth)
                 if q > 1.0 and j and (parents or {}).get(_ends(a, b), np.inf) < 10.0 * q]
        entry["rough_intervals"] = rough
        new, parents = refine(scheme, ratio, parents, nonsmooth, switches,
                              {int(d) for s in at_hand for d in _degrees(s.transcription.scheme)})
        if new == scheme:
            record["message"] = (f"estimate above {tol:g} on intervals that cannot be refined further "
                                 f"(shorter than {MIN_INTERVAL:g} of the horizon at degree {MAX_DEGREE})")
            flag_nonsmooth(sol, tol, record, smoothness, windows)      # the jump windows, as on every other stop
            break
        solved = None
        pilot = companion.transcription.scheme
        if (r == 0 and as_fine(new, pilot) and not finer(new, pilot)
                and pilot.point_count <= SNAP_POINTS * new.point_count):
            # The pilot is at least as fine as the next mesh everywhere and not much larger: take it and
            # its solution, each of its intervals born of the interval it halves. Where the pilot is *finer*
            # than the next mesh (:func:`finer`), the next mesh is solved instead and judged against the
            # pilot: one solve of its points, against one of the pilot's companion (9/7 of the pilot's).
            new, solved = companion.transcription.scheme, companion
            mesh = scheme.mesh_fractions
            parents = {_ends(a, b): float(ratio[min(np.searchsorted(mesh, (a + b) / 2, side="right") - 1, len(ratio) - 1)])
                       for a, b in zip(new.mesh_fractions[:-1], new.mesh_fractions[1:])}
        scheme, warm = new, companion
    if arcs:        # the returned solution's arcs (its own junction times)
        record["input_arcs"] = described(getattr(sol.transcription, "arcs", ()), sol.t_final) or None
    sol = record_switches(name_overshoots(lowest_estimate(record, sol, score, best, tol), record, tol), record)
    optimum_changed(record)
    # The whole refinement's time, estimates and switch checks included (the history's times are its solves')
    record.update(total_time_s=time.perf_counter() - clock[0], total_cpu_s=time.process_time() - clock[1])
    sol.mesh_refinement = record
    return sol
