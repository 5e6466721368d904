"""CPU of one mesh's NLP build inside a refinement, by part (issue 19): what every solve of ``solve(tolerance=...)`` pays.

    python scripts/mesh_refinement_build_costs.py [--runs 15] [--mesh 33x7]

Swing-up (pendulum swing_up, the library's default coordinates: joint). The problem is built and a first
transcription made (its element kinds and their derivatives then cached on the problem, as after a
refinement's first mesh); then, ``runs`` times each, medians of CPU (``time.process_time``, garbage
collection off while timing): the whole build of a later mesh as the refinement makes it
(``mesh_solves.build_mesh`` with the first transcription), the block assembly (``BlockNLP``) alone and
its matrices (``_Entries.matrix``), ``nlpsol`` on the assembled derivatives, and the interpolated warm
start (``guess_from``). Run it at two commits to compare them.
"""
from __future__ import annotations

import argparse
import gc
import statistics
import time

import casadi as ca

from ocp_constraints.ocp import mesh_solves, nlp_assembly
from ocp_constraints.ocp.schemes import Radau
from ocp_constraints.scenes.registry import build_task


def _cpu_ms(fn, runs: int) -> float:
    times = []
    for _ in range(runs):
        cpu = time.process_time()
        fn()
        times.append(1000.0 * (time.process_time() - cpu))
    return statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--mesh", default="33x7", help="NxD: N intervals of Radau degree D")
    args = ap.parse_args(argv)
    N, d = (int(v) for v in args.mesh.split("x"))
    problem = build_task("pendulum", "swing_up")[1]
    first = mesh_solves.build_mesh(problem, Radau(10, degree=3), None)
    coarse = first.solve({})
    scheme = Radau(N, degree=d)
    tr = mesh_solves.build_mesh(problem, scheme, first)        # kinds of degree d built and cached
    spent = {"matrices": 0.0}
    original = nlp_assembly._Entries.matrix

    def matrix(self, nrow, ncol):
        cpu = time.process_time()
        try:
            return original(self, nrow, ncol)
        finally:
            spent["matrices"] += time.process_time() - cpu

    gc.disable()
    try:
        build = _cpu_ms(lambda: mesh_solves.build_mesh(problem, scheme, first), args.runs)
        nlp_assembly._Entries.matrix = matrix
        block = _cpu_ms(lambda: nlp_assembly.BlockNLP(tr.block.n, tr.block.elements, nlp_assembly.derivative_cache(problem)),
                        args.runs)
        nlp_assembly._Entries.matrix = original
        options = {"ipopt.print_level": 0, "print_time": False, **tr.block.derivative_options}
        nlpsol = _cpu_ms(lambda: ca.nlpsol("ocp", "ipopt", tr.nlp, options), args.runs)
        guess = _cpu_ms(lambda: tr.guess_from(coarse), args.runs)
    finally:
        nlp_assembly._Entries.matrix = original
        gc.enable()
    print(f"swing-up, Radau {d} on {N} intervals ({scheme.point_count} points), CPU ms, medians of {args.runs}")
    print(f"  build (as a refinement's later mesh) {build:6.2f}")
    print(f"  of which BlockNLP                   {block:6.2f}   (its matrices {1000.0 * spent['matrices'] / args.runs:5.2f}, mean)")
    print(f"  nlpsol                              {nlpsol:6.2f}")
    print(f"  warm start (guess_from)             {guess:6.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
