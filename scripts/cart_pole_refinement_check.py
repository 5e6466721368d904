"""The newcomer cart-pole (a hinge-force bound with two junctions) solved to a tolerance, its estimate against an
independent reference (issue 19: "the true error at most the estimate and at least a tenth of it").

    python scripts/cart_pole_refinement_check.py [--tolerance 1e-3] [--intervals 100 200]

The reference is the problem in minimal coordinates from Lagrange's equations (``tests/newcomer_reference.py``, plain
CasADi Opti), Radau 7 on uniform meshes with the two junctions our solution located inserted as mesh points (a uniform
mesh converges only like h at a junction: Radau 5 on 400 and 800 intervals differ by 6.5e-3 in the states), started
from our solution. Printed: our estimate, the true error of the states (coordinates and rates, at the reference's
points) and of the hinge force (at our points, relative to the largest load), and the two references' difference,
which bounds the reference's own error. A measurement, not a test.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import newcomer_problems as npb  # noqa: E402  (a script beside this one: the problem and its minimal system)

from ocp_constraints.ocp.switch_detection import detect_switches  # noqa: E402

NAMES = ("cart.x", "pole.psi", "cart.vbar_x", "pole.omega_z")      # (q, qd) of the minimal system, in order
FORCE = ("hinge@pole.F_x", "hinge@pole.F_y", "hinge@pole.F_z")


def reference(sol, mesh: np.ndarray, degree: int = 7) -> dict:
    """The minimal-coordinate problem by Radau ``degree`` on ``mesh``, started from ``sol``."""
    tau = np.array(ca.collocation_points(degree, "radau"))
    t = np.concatenate([[0.0], (mesh[:-1, None] + np.diff(mesh)[:, None] * tau[None, :]).ravel()]) * npb.CARTPOLE["T"]
    start = (np.vstack([sol.interpolate(n, t) for n in NAMES]), np.atleast_2d(sol.interpolate("push", t[1:])))
    return npb.cart_pole_reference(len(mesh) - 1, degree=degree, start=start, mesh=mesh)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tolerance", type=float, default=1e-3)
    ap.add_argument("--intervals", type=int, nargs=2, default=[100, 200], help="the two references' uniform intervals")
    args = ap.parse_args()
    started = time.process_time()
    sol = npb.cart_pole().solve(tolerance=args.tolerance)
    mr = sol.mesh_refinement
    print(f"ours: met {mr['met']}, {sol.transcription.scheme.point_count} points, estimate states "
          f"{mr['estimate']['states']:.2e}, multipliers {mr['estimate']['multipliers']:.2e} "
          f"({time.process_time() - started:.1f} s CPU); J = {sol.objective:.10f}")
    junctions = sorted(w.fraction for w in detect_switches(sol) if w.kind == "junction")
    print("junctions located at", ", ".join(f"{j:.5f}" for j in junctions), "of the horizon")
    s = npb.cart_pole_system()
    force_at = ca.Function("F", [s.q, s.qd, s.w], [npb.cart_pole_hinge_force(s)])
    refs = []
    for n in args.intervals:
        mesh = np.unique(np.r_[np.linspace(0.0, 1.0, n + 1), junctions])
        r = reference(sol, mesh)
        r["F"] = np.array([np.asarray(force_at(r["X"][:2, j], r["X"][2:, j], r["W"][:, j - 1])).ravel()
                           for j in range(1, r["X"].shape[1])])
        print(f"reference on {len(mesh) - 1} intervals: J = {r['objective']:.10f} ({r['iterations']} iterations)")
        refs.append(r)
    coarse, fine = refs
    scale = np.abs(fine["F"]).max()
    states = np.abs(np.vstack([sol.interpolate(n, fine["t"]) for n in NAMES]) - fine["X"]).max()
    ours_F = np.vstack([sol.loads()[k][1:] for k in FORCE]).T
    ref_F = np.vstack([np.interp(sol.t[1:], fine["t"][1:], fine["F"][:, i]) for i in range(3)]).T
    error_F = np.abs(ours_F - ref_F).max(axis=1) / scale
    spread_X = np.abs(np.vstack([np.interp(coarse["t"], fine["t"], fine["X"][i]) for i in range(4)]) - coarse["X"]).max()
    spread_F = np.abs(coarse["F"] - np.vstack([np.interp(coarse["t"][1:], fine["t"][1:], fine["F"][:, i])
                                               for i in range(3)]).T).max() / scale
    worst = sol.t[1:][np.argmax(error_F)] / npb.CARTPOLE["T"]
    print(f"states: true {states:.2e} / estimate {mr['estimate']['states']:.2e} "
          f"({states / mr['estimate']['states']:.2f}); the references differ by {spread_X:.2e}")
    print(f"hinge force (relative to {scale:.2f} N): true {error_F.max():.2e} / estimate "
          f"{mr['estimate']['multipliers']:.2e} ({error_F.max() / mr['estimate']['multipliers']:.2f}), largest at "
          f"{worst:.4f} of the horizon; the references differ by {spread_F:.2e}")


if __name__ == "__main__":
    main()
