"""The objective and its largest gradient at the optimum of every robustness problem (Radau 5 x 10, the refinement's
first mesh), to show which problems the small-objective rule (ocp/objective_scaling.small_objective_scale) touches.

    python scripts/objective_magnitudes.py

Prints per problem the objective at the returned optimum, its largest gradient entry, IPOPT's iterations and whether
the solve was rescaled (``sol.stats["rescaled"]``), then the smallest objective.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ocp_default_robustness  # noqa: E402  (the problems' builders)

from ocp_constraints.ocp.schemes import Radau  # noqa: E402


def main() -> int:
    smallest = np.inf
    for name, build in ocp_default_robustness.PROBLEMS.items():
        try:
            sol = build().solve(Radau(10, degree=5))
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - reported (a builder that needs a missing package exits)
            print(f"{name:32s} not solved: {type(exc).__name__}: {str(exc)[:120]}")
            continue
        f, g = sol.transcription.block.grad_f(sol.decision_vector, [])
        smallest = min(smallest, abs(float(f)))
        print(f"{name:32s} objective {float(f):10.3e}  largest gradient {np.abs(np.asarray(g)).max():9.3e}  "
              f"iterations {sol.iterations:4d}  rescaled {'rescaled' in sol.stats}", flush=True)
    print(f"smallest objective at an optimum: {smallest:.3g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
