"""The hand-written cart-pole (examples/cart_pole_by_hand.py) swung up in least time, its push bounded and no effort
term, refined to a tolerance: a bang-bang input whose arcs the refinement cannot read (issue 19, "What does not hold").

    python scripts/cart_pole_least_time.py [--tolerance 1e-3] [--max-push 20] [--max-refinements 10]

Prints the outcome, the final mesh, the estimate, the push's activity on each mesh (+ upper bound, - lower, . free)
and each refinement's solves and CPU.
"""
from __future__ import annotations

import argparse
import runpy
import time
from pathlib import Path

import ocp_constraints as oc
from ocp_constraints.ocp.switch_detection import activity

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "cart_pole_by_hand.py"


def problem(max_push: float) -> oc.OptimalControlProblem:
    example = runpy.run_path(str(EXAMPLE))["ocp"]          # its model and ends; its own problem is not solved
    ocp = oc.OptimalControlProblem(example.model, t_final=2.0, t_final_bounds=(0.3, 6.0))
    ocp.initial(dict(example.initial_values))
    ocp.final(dict(example.final_values))
    ocp.bound("push", -max_push, max_push)
    ocp.minimize_final_time()
    return ocp


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, default=1e-3)
    ap.add_argument("--max-push", type=float, default=20.0)
    ap.add_argument("--max-refinements", type=int, default=10)
    args = ap.parse_args(argv)
    cpu = time.process_time()
    sol = problem(args.max_push).solve(tolerance=args.tolerance, max_refinements=args.max_refinements)
    mr = sol.mesh_refinement
    print(f"met {mr['met']} in {time.process_time() - cpu:.1f} s of CPU, {sol.transcription.scheme.point_count} points, "
          f"T = {sol.t_final:.9f} s, estimate {mr['estimate']}")
    print(mr["message"])
    s, _ = activity(sol.sample("push"), -args.max_push, args.max_push)
    print("push on the returned mesh:", "".join({1: "+", -1: "-", 0: "."}[int(v)] for v in s))
    for h in mr["history"]:
        print(f"refinement {h['refinement']}: {h['points']} points, {h.get('solves')} solves, CPU {h.get('cpu_s', 0):.1f} s "
              f"+ companion {h.get('companion_cpu_s', 0):.1f} s, estimate "
              + ", ".join(f"{k} {v:.1e}" for k, v in h.get("estimate", {}).items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
