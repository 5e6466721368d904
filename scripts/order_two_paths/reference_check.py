"""The phase reference's own accuracy at 1e-8 (N = 20, s = 5 against N = 40, s = 7), and the 1e-8 solves judged by the finer one.

    python reference_check.py [--coordinates auto|maximal] [--tol 1e-8]"""
import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests"))
sys.path.insert(0, str(HERE))
from run import pendulum  # noqa: E402
from test_refinement_state_arcs import _phase_reference, _true_errors, pendulum_on_a_stop, T_FINAL  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--coordinates", default="auto")
ap.add_argument("--tol", type=float, default=1e-8)
a = ap.parse_args()
coarse, fine = _phase_reference(), _phase_reference(N=40, s=7)
t = np.linspace(0, T_FINAL, 4001)
d = np.array([np.abs(np.subtract(coarse[2](x), fine[2](x))) for x in t]).max(axis=0)
print(f"reference N=20 s=5 vs N=40 s=7: junctions {coarse[0] - fine[0]:.2e} {coarse[1] - fine[1]:.2e} s; psi {d[0]:.2e}, omega {d[1]:.2e}, torque {d[2]:.2e}")
for name, pr in (("bound", pendulum_on_a_stop(a.coordinates)), ("pend_sin", pendulum("pend_sin", a.coordinates))):
    sol = pr.solve(tolerance=a.tol)
    est = sol.mesh_refinement["estimate"]
    for label, ref in (("coarse", coarse), ("fine", fine)):
        ts, tl = _true_errors(sol, *ref)
        print(f"{name} {a.coordinates} {a.tol:g} vs {label} reference: states {ts / est['states']:.2f}, loads {tl / est['multipliers']:.2f} of the estimate")
