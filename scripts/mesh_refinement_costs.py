"""Measurements behind the design of ``solve(tolerance=...)`` (issue 19), reproducible.

    python scripts/mesh_refinement_costs.py [--runs 5] [--skip-calibration]

1. Where a refinement's CPU goes (swing-up, default coordinates): the share of the transcription
   builds in the whole ``problem.solve(tolerance=...)``, medians of ``runs``.
2. Could an estimate without an NLP solve replace the companion? Per interval, the companion's
   difference (safety 1) over the last Legendre coefficient of the solution's polynomial (the size
   of its last term, what a truncation estimate reads), for the swing-up and the cart double
   pendulum (bench/ocp_suite.py) on Radau 3/5/7 with N = 10/20/40: median and range. An estimate
   worth using needs this ratio steady; it is not (printed), so the companion stays.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from numpy.polynomial import legendre

from ocp_constraints.bench import ocp_suite
from ocp_constraints.ocp import transcription as transcription_module
from ocp_constraints.ocp.error_estimate import estimate_error, names
from ocp_constraints.ocp.mesh_companions import companion_of
from ocp_constraints.ocp.schemes import Radau
from ocp_constraints.scenes.registry import build_task


def build_share(runs: int) -> None:
    original = transcription_module.Transcription.__init__
    spent = [0.0]

    def timed(self, *args, **kwargs):
        cpu = time.process_time()
        original(self, *args, **kwargs)
        spent[0] += time.process_time() - cpu

    transcription_module.Transcription.__init__ = timed
    try:
        build_task("pendulum", "swing_up")[1].solve(tolerance=1e-6)       # imports and first-call costs
        for tol in (1e-4, 1e-6, 1e-8):
            totals, builds, solves = [], [], 0
            for _ in range(runs):
                spent[0] = 0.0
                problem = build_task("pendulum", "swing_up")[1]
                cpu = time.process_time()
                sol = problem.solve(tolerance=tol)
                totals.append(time.process_time() - cpu)
                builds.append(spent[0])
                solves = sum(h["solves"] for h in sol.mesh_refinement["history"])
            share = statistics.median(b / t for b, t in zip(builds, totals))
            print(f"swing-up tol {tol:g} ({sol.mesh_refinement['coordinates']} coordinates, {solves} solves): CPU "
                  f"{statistics.median(totals):.3f} s, transcription builds {statistics.median(builds):.3f} s ({share:.0%})")
        fixed = []
        for _ in range(runs):
            problem = build_task("pendulum", "swing_up")[1]
            cpu = time.process_time()
            problem.solve(Radau(10, degree=7))
            fixed.append(time.process_time() - cpu)
        print(f"one fixed solve, Radau 7 N = 10: CPU {statistics.median(fixed):.3f} s")
    finally:
        transcription_module.Transcription.__init__ = original


def last_coefficients(sol, quantity: str) -> np.ndarray:
    """Per interval, the largest last Legendre coefficient of the quantity's polynomial (scaled as the estimate)."""
    tr = sol.transcription
    mesh = tr.scheme.mesh_fractions
    labels = names(sol)[quantity]
    values = np.array([sol.sample(n) for n in labels]).reshape(len(labels), -1)
    scale = 1.0 if quantity == "states" else float(np.abs(values[:, 1:]).max())
    out = []
    for k in range(tr.scheme.intervals):
        idx = np.asarray(tr.interval_points(k))
        idx = idx if quantity == "states" else idx[1:]        # Radau: lambda, inputs at t_k belong to interval k-1
        x = 2 * (tr.fractions[idx] - mesh[k]) / (mesh[k + 1] - mesh[k]) - 1
        a = np.abs(np.linalg.solve(legendre.legvander(x, len(idx) - 1), values[:, idx].T)) / scale
        out.append(a[-1].max())
    return np.array(out)


def calibration() -> None:
    problems = {"swing-up": lambda: build_task("pendulum", "swing_up")[1],
                "cart double pendulum": lambda: ocp_suite.cart_double_pendulum("auto")}
    for name, make in problems.items():
        for d in (3, 5, 7):
            for N in (10, 20, 40):
                problem = make()
                sol = problem.solve(Radau(N, degree=d))
                companion = problem.solve(companion_of(Radau(N, degree=d)), warm_start=sol)
                est = estimate_error(sol, companion, safety=1.0)
                for q in ("states", "multipliers"):
                    diff, last = est.per_interval[q], last_coefficients(sol, q)
                    keep = diff > 1e-11
                    r = diff[keep] / last[keep]
                    if r.size:
                        print(f"{name} radau{d} N={N} {q}: companion difference / last coefficient median "
                              f"{np.median(r):.2e}, range {r.min():.1e} .. {r.max():.1e} (largest difference {diff.max():.1e})")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--skip-calibration", action="store_true")
    args = ap.parse_args(argv)
    build_share(args.runs)
    if not args.skip_calibration:
        calibration()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
