"""How much of a refinement's transcription builds would reusing each degree's element functions save? (issue 19)

    python scripts/mesh_refinement_build_reuse.py [--runs 3] [--tolerance 1e-6] [--problem swing_up|acrobot]

Each mesh of ``problem.solve(tolerance=...)`` is a new :class:`~ocp_constraints.ocp.transcription.Transcription`:
its element kinds (the dynamics at a point, the defects of an interval of degree d, ...) are SX functions whose
mesh enters only through constants (fractions, weights, h), so the same kinds recur on every mesh; only their
instance counts and indices change. Per mesh, :class:`~ocp_constraints.ocp.nlp_assembly.BlockNLP` differentiates
each kind symbolically again (Jacobian, gradient, Lagrangian Hessian) and CasADi builds IPOPT's solver anew.
This profiles the whole refined solve (CPU, cProfile, medians of ``runs`` after a first untimed one) and prints
the CPU of the mesh-independent part (building the element functions: ``Transcription._elements`` minus their
mapping; the symbolic derivatives in ``BlockNLP._differentiate``: ``jacobian``, ``hessian``, ``gradient`` and
``Function`` creation of the derivative functions), of the mesh-dependent part (maps, gathers, ``nlpsol``),
and of IPOPT's iterations (``solver.__call__``), in seconds and as shares of the total.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time


def _problem(name: str):
    if name == "swing_up":
        from ocp_constraints.scenes.registry import build_task

        return build_task("pendulum", "swing_up")[1]
    from ocp_constraints.bench.ocp_suite_run import PROBLEMS

    sp = next(p for p in PROBLEMS if p.name == name)
    return sp.ours(coordinates=sp.fine_coordinates)


def _cumulative(stats: pstats.Stats, file_part: str, function: str) -> float:
    return sum(v[3] for k, v in stats.stats.items() if file_part in k[0] and k[2] == function)


def profile(name: str, tolerance: float) -> dict:
    problem = _problem(name)
    prof = cProfile.Profile(time.process_time)
    cpu = time.process_time()
    prof.enable()
    sol = problem.solve(tolerance=tolerance, progress=False)
    prof.disable()
    total = time.process_time() - cpu
    st = pstats.Stats(prof)
    # A JointTranscription's __init__ runs the Transcription's inside it: the larger of the two is the builds' CPU.
    build = max(_cumulative(st, "ocp/transcription.py", "__init__"), _cumulative(st, "ocp/joint_transcription.py", "__init__"))
    point_functions = _cumulative(st, "ocp/transcription_elements.py", "_point_functions")
    elements = _cumulative(st, "ocp/transcription_elements.py", "_elements")
    differentiate = _cumulative(st, "ocp/nlp_assembly.py", "_differentiate")
    # Inside _differentiate: the symbolic derivatives (mesh-independent) vs the mapped functions (mesh-dependent).
    symbolic = sum(v[3] for k, v in st.stats.items() if "casadi" in k[0] and k[2] in ("jacobian", "hessian", "gradient", "tril"))
    block = _cumulative(st, "ocp/nlp_assembly.py", "__init__")
    nlpsol = sum(v[3] for k, v in st.stats.items() if "casadi" in k[0] and k[2] == "nlpsol")
    return {"total": total, "build": build, "point_functions": point_functions, "elements": elements, "block": block, "differentiate": differentiate,
            "symbolic_derivatives": symbolic, "nlpsol": nlpsol,
            "solves": sum(h["solves"] for h in sol.mesh_refinement["history"]),
            "points": sol.transcription.scheme.point_count}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--tolerance", type=float, default=1e-6)
    ap.add_argument("--problem", default="swing_up")
    args = ap.parse_args(argv)
    profile(args.problem, args.tolerance)           # imports, first calls
    runs = [profile(args.problem, args.tolerance) for _ in range(args.runs)]
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    t = med["total"]
    print(f"{args.problem} at tolerance {args.tolerance:g}: {med['solves']:.0f} solves, final {med['points']:.0f} points; "
          f"CPU under cProfile, medians of {args.runs}:")
    for k in ("build", "point_functions", "elements", "block", "differentiate", "symbolic_derivatives", "nlpsol"):
        print(f"  {k:22s} {med[k]:7.3f} s  {med[k] / t:6.1%}")
    print(f"  {'total':22s} {t:7.3f} s")
    reusable = med["elements"] + med["symbolic_derivatives"]
    print(f"  reusable across meshes (element functions, point functions included, + their symbolic derivatives): at most "
          f"{reusable:.3f} s ({reusable / t:.1%}), less one build of each degree's elements (a degree met once saves "
          f"nothing but the point functions: {med['point_functions']:.3f} s, {med['point_functions'] / t:.1%})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
