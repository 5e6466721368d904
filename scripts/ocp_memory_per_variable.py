"""Peak memory of an optimal-control solve per NLP variable (the constant of the pre-solve memory check).

    python scripts/ocp_memory_per_variable.py

Each mesh runs in its own process (the pendulum swing-up, Radau 3, transcribed and solved); its
peak resident memory is read from ``VmHWM`` in ``/proc/self/status``. The slope of peak memory
against the number of NLP variables is the cost of one more variable; the check in
ocp_constraints/ocp/diagnostics.py (``BYTES_PER_VARIABLE``) uses a rounded-up value of it.
"""
import json
import subprocess
import sys

import numpy as np

CHILD = """
import json, sys
import ocp_constraints as oc
from ocp_constraints.ocp.diagnostics import nlp_variables
_, problem = oc.build_task("pendulum", "swing_up")
method = oc.Radau(int(sys.argv[1]), degree=3)
try:
    problem.solve(method, {"ipopt.max_iter": 30})
except oc.OCPSolveError:
    pass
peak = next(int(line.split()[1]) * 1024 for line in open("/proc/self/status") if line.startswith("VmHWM"))
print(json.dumps({"variables": nlp_variables(problem, method), "peak_bytes": peak}))
"""

if __name__ == "__main__":
    rows = []
    for N in (200, 800, 3200):
        out = subprocess.run([sys.executable, "-c", CHILD, str(N)], capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(f"N = {N}: {rows[-1]['variables']:,} variables, peak {rows[-1]['peak_bytes'] / 2**20:.0f} MiB")
    x = np.array([r["variables"] for r in rows], float)
    y = np.array([r["peak_bytes"] for r in rows], float)
    slope, base = np.polyfit(x, y, 1)
    print(f"peak memory = {base / 2**20:.0f} MiB + {slope:.0f} bytes per variable")
