"""A refined solution against uniform Radau 5 meshes warm-started from it (walker_check.py, arm_reach.py)."""
import time

import numpy as np

import ocp_constraints as oc


def compare(build, sol, names: list[str], intervals: list[int]) -> None:
    """Print, per number of intervals, the uniform mesh's objective and its states' largest difference from ``sol``
    (on 3,001 times; where and in which state)."""
    grid = np.linspace(0.0, sol.t_final, 3001)
    for n in intervals:
        c = time.process_time()
        fixed = build().solve(oc.Radau(mesh=tuple(np.linspace(0, 1, n + 1)), degrees=(5,) * n), warm_start=sol)
        d = {x: np.abs(sol.interpolate(x, grid) - fixed.interpolate(x, grid)) for x in names}
        worst = max(d, key=lambda x: d[x].max())
        print(f"Radau 5 x {n}: J = {fixed.objective:.10f} ({fixed.objective - sol.objective:+.2e}), states differ by "
              f"{d[worst].max():.2e} ({worst} at t = {grid[np.argmax(d[worst])]:.4f} s), {time.process_time() - c:.1f} s CPU")
