"""The true errors between the collocation points too: on the estimate's own grid (error_estimate.sample_grid, 2 times
per collocation point), the library's polynomials (sol.interpolate) against the reference's, beside nc5.py's at the
points alone. Why: Radau collocation is more accurate at its points than between them, and the estimate covers the
polynomials between them (issue 19's "true error" of a trajectory).

    python dense_check.py PROBLEM TOL      (PROBLEM: ft, pend, rp, dpend)
"""
import json
import sys

import numpy as np

import nc5
from ocp_constraints.ocp.error_estimate import sample_grid


def main(problem: str, tol: float) -> None:
    import models as M
    from ref import evaluate
    pr = {"ft": M.free_time, "pend": M.pend_force, "rp": M.rp, "dpend": M.dpend}[problem]()
    sol = pr.solve(tolerance=tol)
    ref = nc5.with_body_states(problem, np.load(f"ref_{problem}.npz", allow_pickle=True)["ref"].item())
    frac = np.unique(np.concatenate([sample_grid(sol.transcription, 2)[0], np.asarray(sol.t) / sol.t_final]))
    frac = frac[frac > 0]
    t = frac * sol.t_final
    out = {"states": 0.0, "multipliers": 0.0}
    for n in list(dict.fromkeys(nc5.STATES[problem] + ref["body_names"])):
        if n not in ref["states"] or n.startswith("elbow."):
            continue
        d = np.asarray(sol.interpolate(n, t), float) - evaluate(ref, n, frac, "state")
        if n in ref["angles"] or n.endswith(".psi"):
            d = (d + np.pi) % (2 * np.pi) - np.pi
        out["states"] = max(out["states"], float(np.abs(d).max()))
    scale = float(sol.mesh_refinement["history"][-1]["load_scale"])
    for n in ref["loads"]:
        d = np.abs(np.asarray(sol.interpolate(n + ".lambda", t), float) - evaluate(ref, n, frac, "load")) / scale
        out["multipliers"] = max(out["multipliers"], float(d.max()))
    at_points = nc5.errors(sol, problem, ref)
    est = sol.mesh_refinement["estimate"]
    print(json.dumps({"problem": problem, "tol": tol, "met": sol.mesh_refinement["met"],
                      "estimate": [est["states"], est["multipliers"]],
                      "true_between_points": [out["states"], out["multipliers"]],
                      "true_at_points": [at_points["states"], at_points["multipliers"]],
                      "ratio_between": [out["states"] / est["states"], out["multipliers"] / est["multipliers"]]}))


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]))
