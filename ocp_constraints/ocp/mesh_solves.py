"""Building and solving one mesh of a refinement (:mod:`.mesh_refinement`), with its retries.

A refinement solves many meshes of one problem, each warm-started from a solution at hand. Two ways a warm
start misleads IPOPT, each met on our problems, and what is done (the solution keeps a ``warm_retry``
record, reported in the refinement's history):

- it runs long (:data:`.mesh_refinement.WARM_FACTOR`): stopped, and solved again from the same start with
  IPOPT's own options (``fallback``), that retry capped too;
- it ends at IPOPT's *acceptable* level (``Solved_To_Acceptable_Level``: 15 iterates in a row within
  ``acceptable_tol`` 1e-6 of IPOPT's scaled optimality, short of the 1e-10 asked). The error estimate compares
  two solutions to the tolerance's size, and such a companion is not one: the whirling ``spin_up`` at 1e-5,
  on 40 intervals of degree 7, had its companion (degree 9) stop there 3e-8 off the optimum in the objective
  (relative 5e-7), so the states' estimate came out 2.2e-3 where the converged companion gives 1.7e-8, and the
  refinement stopped as stalled. From that start IPOPT stops there again with its own options (80 iterations)
  and with the warm ones from its own acceptable point (16); from the problem's own guess it converges (21).
  So the mesh is solved again from the problem's own guess with IPOPT's own options, and that solution is kept
  where it converges fully to the same optimum (objectives within
  :data:`.error_estimate.UNRESOLVED_OBJECTIVE`); else the acceptable one is kept.
"""
from __future__ import annotations

import math
import numbers
import time

import numpy as np

from ..errors import ModelError, OCPSolveError
from .error_estimate import UNRESOLVED_OBJECTIVE
from .schemes import Radau
from .switch_detection import activity, bounded_quantities

ACCEPTABLE = "Solved_To_Acceptable_Level"
COMPLEMENTARITY = "ipopt.compl_inf_tol"
# The warm solves' complementarity where a bound is reached at a tolerance of TIGHTENED_AT or below
# (:func:`complementarity_tolerance`): about the smallest IPOPT reaches in double precision.
COMPLEMENTARITY_FLOOR = 1e-14
TIGHTENED_AT = 1e-4
MUMPS_SCALING = "ipopt.mumps_scaling"
# IPOPT's tolerances on each solve's optimality and feasibility: how close to its NLP's optimum a solve stops.
SOLVER_TOLERANCES = ("ipopt.tol", "ipopt.constr_viol_tol")


def check_tolerance(tolerance) -> float:
    """The tolerance as a float, or a :class:`ModelError` saying what is wrong with it."""
    if isinstance(tolerance, bool) or not isinstance(tolerance, numbers.Real):
        raise ModelError(f"tolerance must be a positive number (the error you accept: states in SI units, "
                         f"multipliers relative to the largest load), got {tolerance!r} "
                         f"({type(tolerance).__name__})")
    tol = float(tolerance)
    if not (math.isfinite(tol) and tol > 0.0):
        raise ModelError(f"tolerance must be a positive finite number, e.g. 1e-6, got {tolerance!r}")
    if tol < 1e-10:
        raise ModelError(f"tolerance {tol:g} is below IPOPT's own tolerance (1e-10) used for every solve; "
                         f"ask for 1e-10 or more")
    return tol


def check_max_refinements(value) -> int:
    """``max_refinements`` as an int >= 0, or a :class:`ModelError` saying what is wrong with it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise ModelError(f"max_refinements must be a whole number >= 0 (refinements after the first solve), "
                         f"got {value!r}")
    return int(value)


def complementarity_tolerance(tol: float, options: dict, first) -> float | None:
    """IPOPT's complementarity tolerance for the warm solves of a refinement to ``tol``: :data:`COMPLEMENTARITY_FLOOR`
    where ``tol`` is 1e-4 or below, the user set none, and an inequality (a bound on an input or a state, a path
    constraint) is active somewhere on ``first``, the first mesh's solution (:func:`.switch_detection.activity`);
    else None (IPOPT's own, 1e-4).

    Why: an interior point holds an active inequality at a distance mu / z from its bound, z its multiplier. At a
    collocation point z carries the point's quadrature weight, so it shrinks with the interval's length h, and it
    falls to zero at a junction: the rounding grows as the refinement shortens the intervals at a junction, the
    one place it refines. A newcomer's rod (|tau| <= 0.9 N m, rest to rest, least int tau^2) on fixed Radau 7 meshes
    with an interval of length h about the junction, torque's error there against the closed form: 2.3e-4, 5.1e-4,
    7.9e-4, 2.6e-3, 4.4e-3 for h = 1e-2, 3e-3, 1e-3, 3e-4, 1e-4 of the horizon with IPOPT's own (its barrier ends
    near 1e-11 under our ``ipopt.tol`` 1e-10; compl_inf_tol 1e-8 and 1e-10 the same), 2.1e-4, 1.2e-4, 5.8e-5, 3.5e-5,
    5.6e-5 with 1e-13. So a refinement at 1e-4 that split towards the junction made its estimate *grow*
    (3.4e-4 -> 1.4e-3 over three refinements) and stalled; with (0.1 tol)^2 (1e-10 at 1e-4, the rule before) and
    1e-12 it stalled too, with 1e-14 it met 1e-4 on 175 points. Below 1e-4 the same: ``(0.1 tol)^2`` (1e-12 at
    1e-5) left the pushes clipped at an input bound and the asymmetric bang-bang block "not met" at 1e-5; with
    1e-14 they meet it, true errors 0.61-0.68 of the estimate (``scripts/refinement_holdouts.py``,
    ``scripts/refinement_newcomer_check.py``; README, "Accuracy on request"). Its cost: more IPOPT iterations
    where a bound is reached, and, with MUMPS's own scaling, slow factorizations (the hinge holdout at 1e-4: 139 s
    of CPU for 72 s; :func:`without_mumps_scaling` turns it off in these solves: 29 s). Only where a bound is reached: the
    swing-up's motor bound is never, and a tighter tolerance cost its companions an IPOPT iteration each. The
    first mesh's cold solve keeps IPOPT's own, and is then solved again under this one, warm from itself
    (:func:`tightened`)."""
    if tol > TIGHTENED_AT or COMPLEMENTARITY in options:
        return None
    if not any(np.any(activity(values, lo, hi)[0]) for _, values, lo, hi, _, _ in bounded_quantities(first)):
        return None
    return COMPLEMENTARITY_FLOOR


def without_mumps_scaling(options: dict) -> dict:
    """The option that turns MUMPS's own scaling off (``{"ipopt.mumps_scaling": 0}``), added to the warm solves that hold
    the complementarity at :data:`COMPLEMENTARITY_FLOOR` (:func:`complementarity_tolerance`), unless the user set it.

    Why: with the barrier driven to 1e-14 the KKT matrices' diagonal spans the ratios z / s of the active bounds, and
    MUMPS's default scaling (IPOPT's 77, chosen by MUMPS) then cost up to about 1 s a factorization: the hinge holdout's
    382-point warm solve took 6.37 s of CPU, 1.61 s unscaled, the same 20 iterations (``results/bench/
    refinement_mumps_scaling.md``). Measured with the tightened complementarity (``results/bench/refinement_compl_floor/``):
    the hinge holdout at 1e-4 met in 29 s for 139 s, the four-bar at 1e-4 met on 970 points in 39 s where it ran past
    the 240 s cap, the rolling-disk drive and the crane 1.5x faster; the holdouts' and the first newcomer's meshes,
    estimates and true errors against their closed forms unchanged, the drive's against its reference too. Only
    there: IPOPT's default weighted matching (``mumps_permuting_scaling``) is kept, and no solve of a problem whose
    bounds are never reached changes. Turning off that matching instead lost the whirling ``spin_up``'s constraint
    loads on its ill-conditioned Jacobian (1.99 of the largest load off) and was not taken."""
    return {} if MUMPS_SCALING in options else {MUMPS_SCALING: 0}


def tightened(cold, options: dict, progress):
    """The first mesh's solution ``cold`` (IPOPT's own complementarity, 1e-4) solved again, warm from itself, with
    ``options`` (holding :func:`complementarity_tolerance`'s), and the wall and CPU seconds it took; ``cold``
    itself where that solve fails. Why: where the first mesh already meets the tolerance (a switch on a mesh point)
    its solution is the one returned, and its rounded corners were left in it: the bang-bang block at 1e-5 was
    "met" with its load's true error 1.34x the estimate (1.1e-7 against 8.2e-8). Cheap: no build, a few
    iterations from a converged start. Its iterations count the cold solve's (:func:`iterations`)."""
    started, cpu = time.perf_counter(), time.process_time()
    try:
        sol = cold.transcription.solve(options, cold, progress=progress, scale_objective=True)
    except OCPSolveError as exc:
        if exc.solution is not None and exc.solution.status.startswith("interrupted"):
            raise
        sol = cold
    else:
        sol.warm_retry = {"status": "complementarity tightened", "iterations": iterations(cold)}
    return sol, time.perf_counter() - started, time.process_time() - cpu


def solver_floor(options: dict) -> float:
    """The accuracy each solve is asked of IPOPT (the looser of ``ipopt.tol`` and ``ipopt.constr_viol_tol``, the
    user's or :data:`.transcription.DEFAULT_IPOPT`'s): the floor of the error estimate (:func:`.error_estimate.estimate_error`)."""
    from .transcription import DEFAULT_IPOPT

    return max(float(options.get(name, DEFAULT_IPOPT[name])) for name in SOLVER_TOLERANCES)


def check_solver_tolerances(options: dict, tol: float) -> None:
    """Refuse IPOPT tolerances looser than the refinement's own ``tol`` (a :class:`ModelError` naming the option):
    each solve would stop that far from its optimum, and the difference of two solves, the estimate, would measure
    IPOPT rather than the mesh (a newcomer's ``ipopt.tol`` 1e-4 under ``tolerance=1e-6`` ran without a word)."""
    for name in SOLVER_TOLERANCES:
        value = options.get(name)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and value > tol:
            raise ModelError(f"'{name}' {value:g} is looser than the tolerance {tol:g} asked of the mesh: each solve would "
                             f"stop that far from its optimum and the error estimate (two solves compared) would measure "
                             f"IPOPT, not the mesh; leave '{name}' at its default (1e-10) or at most {tol:g}, or ask a "
                             f"tolerance of at least {value:g}")


def build_mesh(problem, scheme: Radau, first):
    """The NLP of ``scheme`` in the problem's own coordinates (joint ones under "auto" where they
    apply), not cached on the problem (each mesh is solved once). After the first mesh, the NLP takes
    the first one's equations in joint coordinates, problem view and point functions (the same for every
    mesh of one refinement, whose problem nothing edits: building them again cost ~10 ms, then ~3.5 ms,
    a mesh on the swing-up)."""
    from .joint_transcription import JointTranscription
    from .transcription import Transcription

    if type(first) in (JointTranscription, Transcription):
        return type(first)(problem, scheme, like=first)
    return problem.transcription(scheme, cache=False)


def timed_solve(problem, scheme: Radau, ipopt_options: dict, warm_start, progress, first=None, fallback=None,
                scale_objective: bool = False, arcs=()):
    """Build and solve one mesh; ``first``: an earlier transcription of the same problem. ``fallback``: IPOPT
    options to solve it again with where the warm solve (``warm_start`` given) fails (from the same start) or
    ends at the acceptable level (from the problem's own guess; module notes). ``scale_objective``: the warm
    solves (and the retry from the same start) scale the objective (:mod:`.objective_scaling`). ``arcs``: arcs (an
    input's or a path constraint's) imposed on the bounds (:mod:`.imposed_arcs`). Returns the solution, wall and CPU seconds."""
    started, cpu = time.perf_counter(), time.process_time()
    tr = build_mesh(problem, scheme, first)
    tr.arcs = tuple(arcs)
    warm = warm_start is not None
    scaled = warm and scale_objective
    try:
        try:
            sol = tr.solve(ipopt_options, warm_start, progress=progress, scale_objective=scaled)
        except OCPSolveError as exc:
            failed = exc.solution
            if fallback is None or failed is None or failed.status.startswith("interrupted"):
                raise
            sol = tr.solve(fallback, warm_start, progress=progress, scale_objective=scaled)
            sol.warm_retry = {"status": failed.status, "iterations": failed.iterations}
        if sol.status == ACCEPTABLE and warm and fallback is not None:
            sol = _converged_from_guess(tr, sol, fallback, progress)
    finally:
        elapsed, cpu_used = time.perf_counter() - started, time.process_time() - cpu
    return sol, elapsed, cpu_used


def _converged_from_guess(tr, acceptable, options: dict, progress):
    """``acceptable`` (a warm solve IPOPT ended at its acceptable level) or, where it converges fully to the
    same optimum, the solve of the same NLP from the problem's own guess with ``options`` (module notes)."""
    try:
        sol = tr.solve(options, None, progress=progress)
    except OCPSolveError as exc:
        if exc.solution is not None and exc.solution.status.startswith("interrupted"):
            raise
        return acceptable
    if sol.status == ACCEPTABLE or abs(sol.objective - acceptable.objective) > UNRESOLVED_OBJECTIVE * max(
            abs(acceptable.objective), 1e-12):
        return acceptable
    sol.warm_retry = {"status": ACCEPTABLE, "iterations": acceptable.iterations + getattr(
        acceptable, "warm_retry", {}).get("iterations", 0), "solved_again": "from the problem's guess"}
    return sol


def iterations(sol) -> int:
    """IPOPT iterations of a solve, a failed or acceptable warm attempt's included (:func:`timed_solve`)."""
    return sol.iterations + getattr(sol, "warm_retry", {}).get("iterations", 0)
