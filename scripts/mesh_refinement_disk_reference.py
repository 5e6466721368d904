"""Is the rolling-disk drive's reference good enough to check the refinement at 1e-4? (issue 19)

    python scripts/mesh_refinement_disk_reference.py

The bench (``python -m ocp_constraints.bench.mesh_refinement``) checks the drive against uniform Radau 3 on
200 intervals. This solves a second reference, Radau 7 on 80 intervals warm-started from the first, and prints
how far apart the two references are and how far the refined solve at 1e-4 is from each, beside its
estimate (states absolute, multipliers relative to the largest load, as the bench measures them). When the
two references differ by more than the errors being checked, neither can say whether the estimate holds.
"""
from __future__ import annotations

import time

from ocp_constraints.bench.mesh_refinement import _FineReference, true_error
from ocp_constraints.ocp.schemes import Radau
from ocp_constraints.scenes.registry import build_task


def main() -> None:
    def make():
        return build_task("rolling_disk", "drive")[1]

    cpu = time.process_time()
    a = make().solve(Radau(200, degree=3), progress=False)
    b = make().solve(Radau(80, degree=7), warm_start=a, progress=False)
    print(f"references: radau3 N=200 ({a.status}), radau7 N=80 ({b.status}); {time.process_time() - cpu:.1f} s CPU")
    print("  radau3 N=200 vs radau7 N=80:", _fmt(true_error(a, _FineReference(b).truth)))
    refined = make().solve(tolerance=1e-4, progress=False)
    print(f"refined at 1e-4: met {refined.mesh_refinement['met']}, estimate {_fmt(refined.mesh_refinement['estimate'])}")
    print("  vs radau3 N=200:", _fmt(true_error(refined, _FineReference(a).truth)))
    print("  vs radau7 N=80: ", _fmt(true_error(refined, _FineReference(b).truth)))


def _fmt(errors: dict) -> str:
    return ", ".join(f"{q} {errors[q]:.1e}" for q in ("states", "multipliers"))


if __name__ == "__main__":
    main()
