"""Why Radau keeps acceleration variables from degree 5 on (transcription.Radau.accelerations_from_speeds).

Solves the pendulum swing-up with Radau of every degree, N = 20, once with the
accelerations after t0 taken from the speeds (fewer NLP variables) and once with them
as variables, and prints the time per IPOPT iteration (median of 3 solves) of each.

Run: python scripts/radau_acceleration_variables.py
"""
import statistics

from ocp_constraints.scenes.registry import build_task
from ocp_constraints.ocp.schemes import Radau


def per_iteration_ms(degree: int, from_speeds: bool) -> tuple[float, int, float]:
    # A subclass forcing the choice; the default is the measured cutoff.
    class Forced(Radau):
        @property
        def accelerations_from_speeds(self):
            return self.derivative_matrix if from_speeds else None

    _, problem = build_task("pendulum", "swing_up")
    sols = [problem.solve(Forced(20, degree=degree)) for _ in range(3)]
    ms = statistics.median(1e3 * s.wall_time["solve"] / s.iterations for s in sols)
    return ms, sols[0].iterations, sols[0].objective


print(f"{'degree':>6s} {'from speeds: ms/it':>19s} {'it':>4s} {'variables: ms/it':>17s} {'it':>4s}  default")
for d in range(1, 10):
    a, ia, _ = per_iteration_ms(d, True)
    b, ib, _ = per_iteration_ms(d, False)
    default = "from speeds" if Radau(20, degree=d).accelerations_from_speeds is not None else "variables"
    print(f"{d:6d} {a:19.2f} {ia:4d} {b:17.2f} {ib:4d}  {default}")
