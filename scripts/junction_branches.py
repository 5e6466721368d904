"""Why the newcomer cart-pole's arc was not placed at 1e-5, and the crane's rope tension (issue 19).

    python scripts/junction_branches.py [--out results/bench/refinement_state_arcs/cart_pole_junctions.md]
    python scripts/junction_branches.py --crane

1. *Regularity.* The bound ``|F_hinge|^2 <= f_max^2`` is a mixed constraint: the push enters it through the cart's
   acceleration. Its derivative in the push, ``d(|F|^2)/d(push)``, is printed along a fixed fine solution (Radau 3 on
   800 intervals): where it is near zero the constraint barely depends on the input (it is nearly a constraint of the
   states alone), so on the arc the push that holds it changes fast and the junction's continuity mismatch barely
   moves with the junction's time.
2. *Branches.* Inside ``problem.solve(tolerance=1e-5)``, at the refinement that imposes the arc on its 38-interval
   mesh, the imposed NLP is solved on a grid of (start, end) junction times, each warm from the same solution: the
   start and end mismatches (:func:`ocp_constraints.ocp.imposed_arcs.mismatch`, relative to the bound) and the
   objective. A jump between neighbouring grid points is the NLP landing in another local optimum.
3. *The crane* (``--crane``): the least-time crane's ``d(T^2)/dF`` along a fixed Radau 3 solution on 200 intervals.
   It crosses zero mid-arc, where the load hangs plumb: there the rope-tension bound is not regular, and since
   session 28 that arc is not imposed (:func:`ocp_constraints.ocp.imposed_arcs.regular_over`).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import newcomer_problems as N  # noqa: E402

import ocp_constraints as oc  # noqa: E402
from ocp_constraints.ocp import free_mesh_points, imposed_arcs, junction_times, mesh_refinement  # noqa: E402
from ocp_constraints.ocp.mesh_solves import timed_solve  # noqa: E402


def regularity(intervals: int = 800, crane: bool = False) -> list[str]:
    """``d(|F|^2)/d(push)`` (the path row as the NLP scales it) along a fixed Radau 3 solution; ``crane``: the crane's
    ``d(T^2)/dF`` instead."""
    sol = (N.crane() if crane else N.cart_pole()).solve(oc.Radau(intervals, degree=3))
    tr = sol.transcription
    path = tr.point_pieces[0]["path"]
    j = [c.label for c in tr.nlp_path_constraints].index("rope tension" if crane else "hinge force")
    X, _, L, W, _, _ = (np.asarray(b, float) for b in tr.layout.split(np.asarray(sol.decision_vector, float)))
    t = np.asarray(tr.fractions)
    lines = ["| fraction of the horizon | bounded quantity / its bound | its derivative in the input (1/N) | input (N) |",
             "|---|---|---|---|"]
    for i in range(0, len(t), 24 if not crane else 6):
        if not crane and not 0.30 < t[i] < 0.56:
            continue
        base = float(np.asarray(path(X[:, i], L[:, i], W[:, i], sol.t[i]))[j, 0])
        w = W[:, i].copy()
        w[0] += 1e-4
        slope = (float(np.asarray(path(X[:, i], L[:, i], w, sol.t[i]))[j, 0]) - base) / 1e-4
        lines.append(f"| {t[i]:.4f} | {base:.3f} | {slope:+.4f} | {W[0, i]:+.2f} |")
    return lines


def branches(starts, ends, which: int = 2) -> list[str]:
    """The grid scan at the ``which``-th imposition of ``problem.solve(tolerance=1e-5)``."""
    out: list[str] = []
    calls = []
    original = junction_times.align_junctions

    def scan(problem, scheme, solution, tol, options, progress, first, fallback, scale_objective, tried, score=np.inf):
        calls.append(scheme)
        if len(calls) < which:
            return original(problem, scheme, solution, tol, options, progress, first, fallback, scale_objective, tried,
                            score)
        arcs, scale = imposed_arcs.find_arcs(solution)
        out.append(f"Mesh: {scheme.intervals} intervals, {scheme.point_count} points; arc located at "
                   f"{arcs[0].start:.6f}-{float(arcs[0].end):.6f} of the horizon.\n")
        g = np.zeros((len(starts), len(ends), 2))
        objective, over = np.zeros((len(starts), len(ends))), np.zeros((len(starts), len(ends)))
        for i, s in enumerate(starts):
            for k, e in enumerate(ends):
                trial_arcs = [replace(arcs[0], start=float(s), end=float(e))]
                trial = free_mesh_points.with_junction_points(scheme, [float(s), float(e)])
                sol, _, _ = timed_solve(problem, trial, options, solution, progress, first, fallback, scale_objective,
                                        arcs=trial_arcs)
                g[i, k] = imposed_arcs.mismatch(sol, trial_arcs, scale)
                objective[i, k] = float(sol.objective)
                freed = np.concatenate(imposed_arcs.pinned_points(sol.transcription, trial_arcs)[1])
                over[i, k] = imposed_arcs.values_of(sol, trial_arcs[0])[freed].max() / arcs[0].value - 1.0
        head = "| start \\ end | " + " | ".join(f"{e:.4f}" for e in ends) + " |"
        rule = "|---" * (len(ends) + 1) + "|"
        for title, table in (("start mismatch", g[..., 0]), ("end mismatch", g[..., 1]),
                             ("largest |F|^2 / f_max^2 - 1 where the bound is dropped (next to the junctions)", over),
                             (f"objective less its smallest on the grid, {objective.min():.4f} (the solution the arc "
                              f"was located on: {float(solution.objective):.4f})", objective - objective.min())):
            out.extend([f"\n{title}:\n", head, rule])
            out.extend(f"| {s:.4f} | " + " | ".join(f"{v:+.4f}" for v in row) + " |" for s, row in zip(starts, table))
        raise StopIteration

    mesh_refinement.align_junctions = scan
    try:
        N.cart_pole().solve(tolerance=1e-5)
    except StopIteration:
        pass
    finally:
        mesh_refinement.align_junctions = original
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("results/bench/refinement_state_arcs/cart_pole_junctions.md"))
    ap.add_argument("--crane", action="store_true", help="the crane's rope tension only (section 3), printed")
    args = ap.parse_args(argv)
    if args.crane:
        print("\n".join(regularity(200, crane=True)))
        return 0
    lines = [f"# {__doc__.splitlines()[0]}", "", f"Written by `python scripts/junction_branches.py --out {args.out}`.",
             "", "## 1. Regularity of the hinge-force bound in the push", ""]
    lines += regularity()
    lines += ["", "## 2. Branches of the imposed NLP (second imposition at 1e-5)", ""]
    lines += branches(np.linspace(0.338, 0.352, 8), np.linspace(0.4995, 0.5015, 5))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
