"""One refined library solve of npb.crane() at a tolerance; saves what the comparison needs to an .npz.

    python scripts/crane_reference/library_run.py TOL [OUT.npz]

Saved: met, estimate, load_scale, points, CPU (process) and wall seconds of solve(), t_final, objective, the
library's points t, the states at its points and on a dense normalized grid (sol.interpolate), the rope force on
the load at its points (sol.loads()["rope@load.F_*"]) and midway between its points (its multipliers through each
interval's polynomial, as the library's load_columns computes them), the mesh fractions.
"""
from __future__ import annotations

import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, "/work/main/scripts")
import newcomer_problems as npb  # noqa: E402

NAMES = ("trolley.x", "load.psi", "trolley.vbar_x", "load.omega_z")
FORCE = ("rope@load.F_x", "rope@load.F_y", "rope@load.F_z")


def main():
    tol = float(sys.argv[1])
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path(__file__).parent / f"lib_{tol:g}.npz"
    ocp = npb.crane()
    c0, w0 = time.process_time(), time.perf_counter()
    sol = ocp.solve(tolerance=tol, progress=False)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    rec = sol.mesh_refinement or {}
    T = float(sol.t_final)
    t = np.asarray(sol.t, float)
    hist = rec.get("history", [])
    try:
        points = int(hist[rec.get("returned_refinement", -1)]["points"])
    except Exception:
        points = len(t)
    names = list(sol.sample_names()) if hasattr(sol, "sample_names") else list(sol.sample_columns())
    loads = sol.loads()
    missing = [n for n in NAMES if n not in names] + [n for n in FORCE if n not in loads]
    tau = np.unique(np.r_[np.linspace(0.0, 1.0, 40001), t / T, 0.5 * (t[1:] + t[:-1]) / T])
    tau = tau[(tau >= 0) & (tau <= 1)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Xd = np.vstack([sol.interpolate(n, tau * T) for n in NAMES])
    Xp = np.vstack([sol.sample(n) for n in NAMES])
    Fp = np.vstack([loads[k] for k in FORCE])
    Fu = np.atleast_2d(sol.sample("F"))
    mid = 0.5 * (t[1:] + t[:-1])
    Fmid, mid_note = np.zeros((3, 0)), ""
    try:   # the multipliers between the points, as the library's own interpolation reads them
        from ocp_constraints.mechanics.load_columns import load_columns
        tr, eqs = sol.transcription, sol.trajectory.eqs
        E = tr.interpolation_matrix(mid / T)
        X, lam = np.asarray(sol.X, float), np.asarray(sol.lam, float)
        between = load_columns(eqs, mid, E @ X[: eqs.nq].T, E @ X[eqs.nq:].T, E @ lam.T)
        Fmid = np.vstack([between[k] for k in FORCE])
    except Exception as exc:  # noqa: BLE001
        mid_note = f"{type(exc).__name__}: {exc}"
    try:
        mesh = np.asarray(sol.transcription.scheme.mesh_fractions, float)
    except Exception:  # noqa: BLE001
        mesh = np.zeros(0)
    info = dict(tolerance=tol, met=bool(rec.get("met", False)), estimate={k: float(v) for k, v in rec.get("estimate", {}).items()},
                load_scale=float(rec.get("load_scale", np.nan)), points=points, n_t=len(t), cpu=cpu, wall=wall,
                t_final=T, objective=float(sol.objective), success=bool(sol.success), status=sol.status,
                missing=missing, mid_note=mid_note, interpolate_warnings=sorted({str(w.message)[:160] for w in caught}),
                returned_refinement=rec.get("returned_refinement"), total_cpu_s=rec.get("total_cpu_s"),
                total_time_s=rec.get("total_time_s"), message=str(rec.get("message", ""))[:400], refinements=len(hist),
                jump_windows=rec.get("jump_windows", []), record_keys=sorted(rec.keys()))
    np.savez(out, tau=tau, Xd=Xd, t=t, Xp=Xp, Fp=Fp, Fu=Fu, mid=mid, Fmid=Fmid, mesh=mesh, info=json.dumps(info))
    print(json.dumps(info, indent=1, default=str))


if __name__ == "__main__":
    main()
