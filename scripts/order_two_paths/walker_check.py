"""The suite's walker (three path constraints of the coordinates alone) refined to 1e-5 with its arcs imposed, against
uniform fixed meshes (Radau 5 on 80, 160, 320 intervals): objectives, and the states' largest difference on a grid.

    python walker_check.py [--tol 1e-5]"""
import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import ocp_default_robustness  # noqa: E402
from uniform import compare  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--tol", type=float, default=1e-5)
ap.add_argument("--intervals", type=int, nargs="*", default=[80, 160, 320])
a = ap.parse_args()
build = ocp_default_robustness.PROBLEMS["suite:walker"]
c = time.process_time()
sol = build().solve(tolerance=a.tol)
rec = sol.mesh_refinement
print(f"refined {a.tol:g}: met {rec['met']}, {len(sol.t)} points, {time.process_time() - c:.1f} s CPU, J = {sol.objective:.10f}, "
      f"estimate states {rec['estimate']['states']:.2e} loads {rec['estimate']['multipliers']:.2e}")
for arc in rec.get("input_arcs", []):
    print("  arc", {k: arc[k] for k in ("quantity", "value", "start", "end", "state", "path", "via")})
pr0 = build()
compare(build, sol, pr0.model.coordinate_names + pr0.model.speed_names, a.intervals)
