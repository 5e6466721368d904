"""IPOPT options for the warm-started solves of a refinement (issue 19): CPU of one warm solve per variant.

    python scripts/mesh_refinement_ipopt_options.py [--repeats 7] [--problems swing_up acrobot cart_double_pendulum]

Per problem, a coarse solve (Radau 3, 10 intervals; the suite's problems: Radau 7 on 20) is the warm
start of solves on two finer meshes (the swing-up: the pilot Radau 7 N = 20 and a companion Radau 9
N = 20; the suite's problems: Radau 7 on 40 and 80 intervals, the sizes their refinements reach), each
built anew (as the refinement does) and solved with ``mesh_refinement.WARM_IPOPT`` plus each variant.
The variants run interleaved, one of each per repeat, so that a drifting load hits all alike; printed:
IPOPT iterations, the objective (the variants must agree), and the median CPU of ``Transcription.solve``
(``time.process_time``: guess, ``nlpsol``, IPOPT, completion).
"""
from __future__ import annotations

import argparse
import statistics
import time

from ocp_constraints.ocp.mesh_refinement import WARM_IPOPT
from ocp_constraints.ocp.mesh_solves import build_mesh
from ocp_constraints.ocp.schemes import Radau

VARIANTS = {
    "default (pivot order auto)": {},
    "mumps_pivot_order 0 (AMD)": {"ipopt.mumps_pivot_order": 0},
    "mumps_scaling 0": {"ipopt.mumps_scaling": 0},
    "AMD + mumps_scaling 0": {"ipopt.mumps_pivot_order": 0, "ipopt.mumps_scaling": 0},
    "constr_mult_init_max 0": {"ipopt.constr_mult_init_max": 0},
    "AMD + constr_mult_init_max 0": {"ipopt.mumps_pivot_order": 0, "ipopt.constr_mult_init_max": 0},
}


def _case(name: str):
    if name == "swing_up":
        from ocp_constraints.scenes.registry import build_task

        return build_task("pendulum", "swing_up")[1], Radau(10, degree=3), [Radau(20, degree=7), Radau(20, degree=9)]
    from ocp_constraints.bench.ocp_suite_run import PROBLEMS

    sp = next(p for p in PROBLEMS if p.name == name)
    return sp.ours(coordinates=sp.fine_coordinates), Radau(20, degree=7), [Radau(40, degree=7), Radau(80, degree=7)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--problems", nargs="+", default=["swing_up", "acrobot", "cart_double_pendulum"])
    args = ap.parse_args(argv)
    for name in args.problems:
        problem, coarse_scheme, fine = _case(name)
        first = problem.transcription(coarse_scheme, cache=False)
        coarse = first.solve({})
        for scheme in fine:
            cpu = {v: [] for v in VARIANTS}
            result = {}
            for _ in range(args.repeats):
                for v, options in VARIANTS.items():
                    tr = build_mesh(problem, scheme, first)
                    started = time.process_time()
                    sol = tr.solve({**WARM_IPOPT, **options}, coarse)
                    cpu[v].append(time.process_time() - started)
                    result[v] = (sol.iterations, float(sol.objective))
            for v in VARIANTS:
                print(f"{name:22s} radau{scheme.degree} N={scheme.intervals:<4d} {v:28s} iterations {result[v][0]:3d}  "
                      f"J {result[v][1]:.12g}  CPU median {1e3 * statistics.median(cpu[v]):7.1f} ms", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
