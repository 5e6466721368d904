"""How good the rolling-disk drive's reference for the refinement table is (issue 19; ``bench/mesh_refinement.py``).

    python scripts/drive_reference_spread.py

The reference (``bench.references.junction_mesh_solution``) is Radau 7 with mesh points at the friction cone's
junctions, which the drive's solution to 1e-4 locates. Printed: the same reference on 50 and on 100 intervals
against each other, and the uniform Radau 3 meshes on 400 and 800 intervals (the reference before) against each
other: their largest differences of states (absolute) and multipliers (relative to the largest load).
"""
from __future__ import annotations

from ocp_constraints.bench.mesh_refinement import _FineReference, true_error
from ocp_constraints.bench.references import junction_mesh_solution
from ocp_constraints.ocp.schemes import Radau
from ocp_constraints.scenes.registry import build_task


def make():
    return build_task("rolling_disk", "drive")[1]


def main() -> None:
    located = make().solve(tolerance=1e-4)
    pairs = {"junction mesh, Radau 7 on 50 against 100 intervals":
             [junction_mesh_solution(make, located, intervals=n) for n in (50, 100)],
             "uniform Radau 3 on 400 against 800 intervals":
             [make().solve(Radau(n, degree=3), warm_start=located) for n in (400, 800)]}
    for label, (coarse, fine) in pairs.items():
        e = true_error(coarse, _FineReference(fine).truth)
        print(f"{label}: states {e['states']:.1e}, multipliers {e['multipliers']:.1e} "
              f"(J {coarse.objective:.12f} / {fine.objective:.12f})")


if __name__ == "__main__":
    main()
