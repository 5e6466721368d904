"""The suite's walker (three path constraints of the coordinates alone) refined to 1e-5 with its arcs imposed, against
uniform fixed meshes (Radau 5 on 80, 160, 320 intervals): objectives, and the states' largest difference on a grid.

    python walker_check.py [--tol 1e-5]"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
import ocp_default_robustness  # noqa: E402
import ocp_constraints as oc  # noqa: E402

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
names = pr0.model.coordinate_names + pr0.model.speed_names
T = sol.t_final
grid = np.linspace(0.0, T, 3001)
for n in a.intervals:
    c = time.process_time()
    fixed = build().solve(oc.Radau(mesh=tuple(np.linspace(0, 1, n + 1)), degrees=(5,) * n), warm_start=sol)
    d = {x: np.abs(sol.interpolate(x, grid) - fixed.interpolate(x, grid)) for x in names}
    worst = max(d, key=lambda x: d[x].max())
    print(f"Radau 5 x {n}: J = {fixed.objective:.10f} ({fixed.objective - sol.objective:+.2e}), states differ by {d[worst].max():.2e} "
          f"({worst} at t = {grid[np.argmax(d[worst])]:.4f} s), {time.process_time() - c:.1f} s CPU")
