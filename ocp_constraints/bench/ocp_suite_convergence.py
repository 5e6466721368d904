"""The suite's accuracy step: ours and the minimal-coordinate reference on a chain of meshes.

Why a chain, not one fine mesh: where an optimum rides a bound (the four-bar's pin force), the
bound's switching times fall anywhere inside a collocation interval, and where it has sharp peaks
(the acrobot's elbow torque) short intervals are needed; fixed-mesh collocation then converges
slowly and irregularly. At Radau 7 the minimal acrobot's objective changes by 5.4e-4 from N = 40
to 80, then by 1.3e-6 and 1.2e-9; the four-bar's by 4e-5, 6e-6, 1e-7 (sign changing) and 1.1e-8.
One reference mesh, or its comparison with half the intervals, does not say whether the
reference has converged.

On each mesh ``(N, degree)`` of the chain (``N`` doubling), in order:

1. ours (:meth:`~ocp_constraints.OptimalControlProblem.solve` on ``Radau(N, degree)``),
   warm-started from our solution on the previous mesh, the first from the coarse timed solve;
2. the reference: the minimal-coordinate problem by :func:`.ocp_suite_peers.collocate`, warm-started
   from our solution on the same mesh mapped into minimal coordinates (:mod:`.ocp_suite_maps`), so
   that both are the same local optimum (the swing-ups have several, and on coarse meshes the
   optimum reached from the previous mesh's solution jumps between them); then solved to IPOPT's
   tolerance (1e-10) on its own equations. Without a map: from the previous reference.

The chain stops once it has at least :data:`MIN_MESHES` meshes and the reference changed by at
most :data:`CONVERGED` (relative) over the last doubling, or at its last mesh. The converged
reference ``J_ref`` is the finest reference; the evidence is its change over the last doubling
and the ratio of the last two changes (a Richardson-style tail ``|D_k| r / (1 - r)`` for a
ratio ``r < 1``). Against it: our relative deviation on every mesh and the first mesh from which
it stays within :data:`TARGET` (issue 13's 1e-6), and on every mesh the agreement of the two
formulations on the same mesh.
"""
from __future__ import annotations

import time

import numpy as np

from .ocp_suite_peers import collocate

TARGET = 1e-6
CONVERGED = 1e-8
MIN_MESHES = 3
# Warm-started solves begin near their optimum; a small first barrier parameter saves the
# iterations of driving IPOPT's default 0.1 down (as ocp/mesh_refinement.py does).
WARM = {"ipopt.mu_init": 1e-6}


def chain(first: tuple[int, int], last_intervals: int) -> list[tuple[int, int]]:
    """Meshes ``(N, d), (2N, d), ...`` up to ``last_intervals`` intervals."""
    N, d = first
    out = []
    while N <= last_intervals:
        out.append((N, d))
        N *= 2
    return out


def _previous(ref: dict):
    """A start for :func:`collocate` from its own earlier result (linear in time between its points)."""
    t, X, U = ref["t"], ref["x"], ref["u"]
    return lambda s: (np.array([np.interp(s, t, x) for x in X]), np.array([np.interp(s, t[1:], u) for u in U]))


def converge(sp, mp, problem, coarse, meshes: list[tuple[int, int]], log=print, stop_if_interrupted=None) -> dict:
    """Run the chain ``meshes`` (see the module docstring) for suite problem ``sp`` (our problem
    ``problem``, its coarse solution ``coarse`` or None) and its minimal problem ``mp``. Returns the
    per-mesh lists and the summary columns of the suite's table; times in seconds (wall, CPU)."""
    import ocp_constraints as oc

    steps, sol, ref = [], coarse, None
    for k, (N, d) in enumerate(meshes):
        started, cpu = time.perf_counter(), time.process_time()
        try:
            sol = problem.solve(oc.Radau(N, degree=d), {**WARM, "ipopt.max_iter": 500} if sol is not None else None,
                                warm_start=sol, progress=False)
        except oc.OCPSolveError as exc:
            sol = exc.solution
        if stop_if_interrupted is not None:
            stop_if_interrupted(sol)
        ours_s, ours_cpu = time.perf_counter() - started, time.process_time() - cpu
        if sp.states is not None:
            start = (lambda s, fine=sol: sp.states(fine, sp.inputs, s))
        else:
            start = None if ref is None else _previous(ref)
        cpu = time.process_time()
        ref = collocate(mp, N, d, WARM if start is not None else None, start=start)
        ref["cpu_s"] = time.process_time() - cpu
        steps.append({"mesh": f"Radau{d} N={N}", "N": N, "degree": d, "ours_success": bool(sol.success),
                      "ours_iterations": sol.iterations, "ours_objective": float(sol.objective), "ours_s": ours_s,
                      "ours_cpu_s": ours_cpu, "ref_success": ref["success"], "ref_iterations": ref["iterations"],
                      "ref_objective": ref["objective"], "ref_s": ref["solve_s"], "ref_cpu_s": ref["cpu_s"]})
        log(f"  {sp.name}: Radau{d} N={N}: ours J = {sol.objective:.12g} ({sol.status}, {sol.iterations} it, "
            f"{ours_s:.1f} s, {ours_cpu:.1f} s CPU); reference J = {ref['objective']:.12g} ({ref['iterations']} it, "
            f"{ref['solve_s']:.1f} s, {ref['cpu_s']:.1f} s CPU)")
        if k + 1 >= MIN_MESHES and _change(steps, -1) <= CONVERGED:
            break
    return summarize(steps)


def _change(steps: list[dict], k: int) -> float:
    """Relative change of the reference from mesh ``k - 1`` to mesh ``k``."""
    a, b = steps[k - 1]["ref_objective"], steps[k]["ref_objective"]
    return abs(b - a) / abs(b)


def summarize(steps: list[dict]) -> dict:
    """The suite's columns from the chain's ``steps`` (one dict per mesh, coarse to fine)."""
    J = steps[-1]["ref_objective"]
    for s in steps:
        s["deviation"] = abs(s["ours_objective"] - J) / abs(J)
        s["equal_mesh"] = abs(s["ours_objective"] - s["ref_objective"]) / abs(s["ref_objective"])
    changes = [_change(steps, k) for k in range(1, len(steps))]
    ratio = changes[-1] / changes[-2] if len(changes) >= 2 and changes[-2] > 0 else float("nan")
    tail = changes[-1] * ratio / (1 - ratio) if ratio < 1 else float("nan")
    # The first mesh from which ours stays within TARGET, among the meshes coarser than the
    # reference's finest (on that one the comparison is of two formulations on the same mesh).
    within = None
    for s in reversed(steps[:-1]):
        if not (s["ours_success"] and s["deviation"] <= TARGET):
            break
        within = s["mesh"]
    return {"chain": steps, "fine_setting": steps[-1]["mesh"], "fine_success": all(s["ours_success"] for s in steps),
            "fine_objective": steps[-1]["ours_objective"], "fine_s": sum(s["ours_s"] for s in steps),
            "fine_cpu_s": sum(s["ours_cpu_s"] for s in steps),
            "reference_setting": f"minimal-coordinate {steps[-1]['mesh']}",
            "reference_success": all(s["ref_success"] for s in steps), "reference_objective": J,
            "reference_change": changes[-1] if changes else float("nan"), "reference_ratio": ratio,
            "reference_tail": tail, "reference_s": sum(s["ref_s"] for s in steps),
            "reference_cpu_s": sum(s["ref_cpu_s"] for s in steps),
            "within_target_from": within or "not reached",
            "deviations": "; ".join(f"{s['N']}: {s['deviation']:.1e}" for s in steps[:-1]),
            "agreement": steps[-2]["deviation"] if len(steps) > 1 else float("nan"),
            "agreement_equal_mesh": max(s["equal_mesh"] for s in steps)}
