"""A two-link arm (the eleventh newcomer's, tau1 unbounded) whose tip must keep a distance from the shoulder,
|tip|^2 >= D2 (the elbow folds to 3.09 rad unconstrained; D2 = 0.13 m^2 stops it near 2.5 rad): a path constraint of
the coordinates alone, nonlinear in them, with two inputs. Refined to TOL; compared with uniform Radau 5
meshes (a second method: fixed meshes carry the kink's floor, so they converge to it slowly). Found in session 32: the
refined solve ends at J = 9.7551 (the elbow folding one way, as from the first mesh), and uniform Radau 5 x 160, cold
or warm from it, at J = 8.0218 (the elbow first swinging the other way, to -2.18 rad): two local optima, the first
mesh's basin deciding which (a multi-start, ``solve(starts=N)``, is the remedy; README, "Which optimum a cold start
reaches"), so the fixed meshes here judge nothing.

    python arm_reach.py TOL [--coordinates auto|maximal] [--d2 D2] [--intervals 160 320]"""
import argparse
import sys
import time
from pathlib import Path

import casadi as ca

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "refinement_newcomer11"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import models  # noqa: E402
from uniform import compare  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("tol", type=float)
ap.add_argument("--coordinates", default="auto")
ap.add_argument("--d2", type=float, default=0.13)
ap.add_argument("--intervals", type=int, nargs="*", default=[])
a = ap.parse_args()
L2 = models.PARAMS["arm_sat"]["L2"]


def build():
    pr, _ = models.build("arm_sat", bounded=False)
    pr.coordinates = a.coordinates
    psi = pr.quantity("l2.psi")
    tip = (pr.quantity("l2.x") + L2 / 2 * ca.sin(psi), pr.quantity("l2.y") - L2 / 2 * ca.cos(psi))
    pr.subject_to(tip[0] ** 2 + tip[1] ** 2, lower=a.d2, label="reach")
    return pr


c = time.process_time()
sol = build().solve(tolerance=a.tol)
rec = sol.mesh_refinement
print(f"refined {a.tol:g} ({a.coordinates}): met {rec['met']}, {len(sol.t)} points, {time.process_time() - c:.1f} s CPU, "
      f"J = {sol.objective:.10f}, estimate states {rec['estimate']['states']:.2e} loads {rec['estimate']['multipliers']:.2e}")
print("  ", rec["message"][:300])
for arc in rec.get("input_arcs", []):
    print("  arc", {k: arc[k] for k in ("quantity", "value", "start", "end", "state", "path", "via")})
compare(build, sol, ["l1.psi", "l2.psi", "l1.omega_z", "l2.omega_z"], a.intervals)
