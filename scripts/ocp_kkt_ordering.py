"""Where a cold solve's time goes, and what MUMPS's ordering changes: IPOPT's own timing statistics of one solve.

    python scripts/ocp_kkt_ordering.py [--coordinates maximal] [--degree 5] [--intervals 10] [OPTION=VALUE ...]

The suite's walker (``bench/ocp_suite_3d.walker``), compiled elements off, solved once from its guess; printed: IPOPT's
iterations, its time in the linear solver (``PDSystemSolverTotal``) and the whole CPU. Extra IPOPT options as
``ipopt.mumps_pivot_order=6`` (results/bench/ocp_mumps_pivot_order.md).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import sys
import tempfile
import time

import ocp_constraints as oc
from ocp_constraints.bench.ocp_suite_3d import walker


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--coordinates", default="maximal")
    ap.add_argument("--degree", type=int, default=5)
    ap.add_argument("--intervals", type=int, default=10)
    ap.add_argument("options", nargs="*", help="IPOPT options, NAME=VALUE")
    args = ap.parse_args(argv)
    extra = {k: (int(v) if v.lstrip("-").isdigit() else v) for k, v in (o.split("=", 1) for o in args.options)}
    problem = walker(coordinates=args.coordinates)
    problem.compiled = "never"
    # IPOPT prints its statistics on the process's stdout (C level): read them back from a file.
    with tempfile.TemporaryFile(mode="w+") as out:
        saved = os.dup(1)
        os.dup2(out.fileno(), 1)
        try:
            cpu = time.process_time()
            sol = problem.solve(oc.Radau(args.intervals, degree=args.degree), ipopt_options={
                "ipopt.print_timing_statistics": "yes", "ipopt.print_level": 4, **extra})
            cpu = time.process_time() - cpu
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
        out.seek(0)
        text = out.read()
    linear = re.search(r"PDSystemSolverTotal\.*:\s*([\d.]+)", text)
    print(f"walker ({args.coordinates}, Radau {args.degree} x {args.intervals}) {extra or 'IPOPT defaults'}: "
          f"{sol.iterations} iterations, J {sol.objective:.8g}, linear solver {float(linear.group(1)) if linear else float('nan'):.2f} s, "
          f"CPU {cpu:.2f} s")
    return 0


if __name__ == "__main__":
    with contextlib.suppress(BrokenPipeError):
        raise SystemExit(main())
