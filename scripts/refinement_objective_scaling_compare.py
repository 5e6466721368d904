"""The refinement with and without the warm solves' objective scale (ocp/objective_scaling.py), side by side.

    python scripts/refinement_objective_scaling_compare.py TOL PROBLEM [PROBLEM ...]

PROBLEM: a name of ``scripts/ocp_default_robustness.py`` (``newcomer:crane``, ``suite:walker``, ...). Each is built
afresh and solved with ``solve(tolerance=TOL)`` twice: with the library's scale, and with a user's own
``ipopt.obj_scaling_factor`` 1 (IPOPT's own, as before the scale). Printed per run: met, final intervals / points,
objective, CPU (``time.process_time``) and the scale of each mesh's solve.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ocp_default_robustness  # noqa: E402


def run(name: str, tol: float, options: dict) -> str:
    problem = ocp_default_robustness.PROBLEMS[name]()
    cpu = time.process_time()
    sol = problem.solve(tolerance=tol, ipopt_options=options, progress=False)
    cpu = time.process_time() - cpu
    record = sol.mesh_refinement
    scales = " ".join(f"{h.get('objective_scale', 1.0):.3g}" for h in record["history"])
    return (f"{'met' if record['met'] else 'not met'}, {len(record['degrees'])} / {sol.transcription.scheme.point_count} "
            f"points, objective {sol.objective:.10g}, CPU {cpu:.1f} s; scales {scales}")


def main(argv: list[str]) -> None:
    tol, names = float(argv[0]), argv[1:]
    for name in names:
        for label, options in (("scaled", {}), ("IPOPT's own", {"ipopt.obj_scaling_factor": 1.0})):
            print(f"{name} {tol:g} {label}: {run(name, tol, options)}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
