"""A block on a rail tracking samples at 30 Hz (linear between them), solved to a tolerance with and without mesh
points at the samples (ocp/time_breakpoints.py), against Pontryagin's two-point problem solved by SciPy's solve_bvp
(the problem and its reference: ocp_constraints/bench/sampled_tracking.py).

    python scripts/refinement_time_breakpoints.py [--tolerances 1e-5 1e-6 1e-7] [--cap 120] [--samples 31]
                                                  [--mumps-scaling-off]

Each solve in its own process, its CPU capped at ``--cap`` s; "without" replaces the first mesh's breakpoints by the
plain first mesh (the code before). Printed: met, final points, CPU of ``solve``, the states' estimate and the true
error of x and v at the solution's points, or the cap. ``--samples N``: N samples over the second instead of 31;
``--mumps-scaling-off``: IPOPT's ``mumps_scaling`` 0 in every solve (at 101 samples MUMPS's own scaling spends
minutes in one factorization).
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np


def one(tolerance: float, without: bool, samples: int, unscaled: bool) -> dict:
    import ocp_constraints.bench.sampled_tracking as st
    import ocp_constraints.ocp.mesh_refinement as mr

    st.SAMPLES = np.linspace(0.0, st.T, samples)
    st.VALUES = 0.1 * np.sin(2 * np.pi * st.SAMPLES)

    if without:
        mr.with_breakpoints = lambda scheme, problem: scheme
    ref = st.pontryagin_solution()
    cpu = time.process_time()
    sol = st.sampled_tracking_block().solve(tolerance=tolerance,
                                            ipopt_options={"ipopt.mumps_scaling": 0} if unscaled else None)
    cpu = time.process_time() - cpu
    r, t = sol.mesh_refinement, np.asarray(sol.t)
    true = max(np.abs(np.asarray(sol.sample(n)) - ref(t)[k]).max() for k, n in enumerate(("block.x", "block.vbar_x")))
    return {"met": r["met"], "points": r["history"][-1]["points"], "cpu_s": cpu, "estimate": r["estimate"]["states"],
            "true_x_v": true}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerances", type=float, nargs="+", default=[1e-5, 1e-6, 1e-7])
    ap.add_argument("--cap", type=int, default=120)
    ap.add_argument("--samples", type=int, default=31)
    ap.add_argument("--mumps-scaling-off", action="store_true")
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--without", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one is not None:
        print("ROW " + json.dumps(one(args.one, args.without, args.samples, args.mumps_scaling_off)))
        return 0
    for tol in args.tolerances:
        for without in (False, True):
            cmd = [sys.executable, __file__, "--one", repr(tol), "--samples", str(args.samples)]
            cmd += (["--without"] if without else []) + (["--mumps-scaling-off"] if args.mumps_scaling_off else [])
            p = subprocess.run(cmd, capture_output=True, text=True,
                               preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_CPU, (args.cap, args.cap)))
            rows = [ln[4:] for ln in p.stdout.splitlines() if ln.startswith("ROW ")]
            label = f"{tol:g} {'without' if without else 'with   '} breakpoints:"
            if not rows:
                print(f"{label} no result within {args.cap} s of CPU (exit {p.returncode})", flush=True)
                continue
            r = json.loads(rows[0])
            print(f"{label} met {r['met']}, {r['points']} points, {r['cpu_s']:.1f} s CPU, states' estimate "
                  f"{r['estimate']:.1e}, true error of x and v {r['true_x_v']:.1e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
