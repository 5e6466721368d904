"""The swing-up (examples/swing_up.py's rod) in other units and over other horizons, solved to a tolerance.

    python scripts/refinement_units_and_horizons.py [--tolerance 1e-5] [--cases NAME ...] [--start N]

Each case in its own process (CPU capped at 300 s): a rod of another mass and length (time and torque bound scaled by
dimensional analysis unless the case says otherwise), or the 1 m rod over a longer horizon. Printed: met, final
points, CPU of ``solve``, IPOPT's objective scale in the last solve, the estimate and the message's start. ``--start N``: start from Radau N x 5 instead of the
default first mesh (the advice of a refinement that stops on an unresolved mesh).
"""
from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time

import casadi as ca
import numpy as np

# name -> (mass kg, length m, horizon s, torque bound N m)
CASES = {
    "metre_2s": (1.0, 1.0, 2.0, 20.0),
    "tonne_2s": (1000.0, 1.0, 2.0, 2e4),
    "centimetre_gram_0.2s": (1e-3, 1e-2, 0.2, 2e-4),
    "centimetre_gram_0.5s": (1e-3, 1e-2, 0.5, 1.0),
    "ten_metres_10s": (1.0, 10.0, 10.0, 2000.0),
    "metre_20s": (1.0, 1.0, 20.0, 20.0),
    "metre_60s": (1.0, 1.0, 60.0, 20.0),
}


def swing_up(mass: float, length: float, T: float, bound: float):
    import ocp_constraints as oc

    model = oc.Model("rod", gravity=(0.0, -9.81, 0.0))
    rod = model.add_body("rod", mass, mass * length**2 * np.diag([1 / 12, 0.0, 1 / 12]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, length / 2, 0.0]), axis=(0, 0, 1))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    ocp = oc.OptimalControlProblem(model, t_final=T)
    ocp.bound("motor", -bound, bound)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    ocp.set_guess("rod.psi", lambda t: math.pi * t / T - np.sin(math.pi * t / T))
    return ocp


def one(name: str, tolerance: float, start: int | None) -> dict:
    import ocp_constraints as oc

    cpu = time.process_time()
    method = None if start is None else oc.Radau(start, degree=5)
    sol = swing_up(*CASES[name]).solve(method, tolerance=tolerance)
    r = sol.mesh_refinement
    return {"case": name, "met": r["met"], "points": r["history"][-1]["points"], "cpu_s": time.process_time() - cpu,
            "estimate": r["estimate"], "objective_scale": getattr(sol, "objective_scale", 1.0), "message": r["message"][:160]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, default=1e-5)
    ap.add_argument("--cases", nargs="+", default=list(CASES))
    ap.add_argument("--start", type=int, default=None)
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        print("ROW " + json.dumps(one(args.one, args.tolerance, args.start)))
        return 0
    for name in args.cases:
        cmd = [sys.executable, __file__, "--one", name, "--tolerance", repr(args.tolerance)]
        cmd += [] if args.start is None else ["--start", str(args.start)]
        p = subprocess.run(cmd, capture_output=True, text=True,
                           preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_CPU, (300, 300)))
        rows = [ln[4:] for ln in p.stdout.splitlines() if ln.startswith("ROW ")]
        if not rows:
            print(f"{name:22s} no result (exit {p.returncode}): {p.stderr.strip().splitlines()[-1:]}")
            continue
        r = json.loads(rows[0])
        est = ", ".join(f"{k} {v:.1e}" for k, v in (r["estimate"] or {}).items())
        print(f"{name:22s} met {str(r['met']):5s} {r['points']:5d} points {r['cpu_s']:6.1f} s CPU  objective scale "
              f"{r['objective_scale']:7.1e}  estimate {est}\n{'':22s} {r['message']}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
