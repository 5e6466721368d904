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

import time

from ..errors import OCPSolveError
from .error_estimate import UNRESOLVED_OBJECTIVE
from .schemes import Radau

ACCEPTABLE = "Solved_To_Acceptable_Level"


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


def timed_solve(problem, scheme: Radau, ipopt_options: dict, warm_start, progress, first=None, fallback=None):
    """Build and solve one mesh; ``first``: an earlier transcription of the same problem. ``fallback``: IPOPT
    options to solve it again with where the warm solve (``warm_start`` given) fails (from the same start) or
    ends at the acceptable level (from the problem's own guess; module notes). Returns the solution, wall and
    CPU seconds."""
    started, cpu = time.perf_counter(), time.process_time()
    tr = build_mesh(problem, scheme, first)
    try:
        try:
            sol = tr.solve(ipopt_options, warm_start, progress=progress)
        except OCPSolveError as exc:
            failed = exc.solution
            if fallback is None or failed is None or failed.status.startswith("interrupted"):
                raise
            sol = tr.solve(fallback, warm_start, progress=progress)
            sol.warm_retry = {"status": failed.status, "iterations": failed.iterations}
        if sol.status == ACCEPTABLE and warm_start is not None and fallback is not None:
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
