"""Where an hp refinement's time goes, for one suite problem or the switching cases (issue 19), reproducible.

    python scripts/hp_refinement_profile.py walker --tolerance 1e-4 [--top 25]
    python scripts/hp_refinement_profile.py "minimum-time swing-up" --tolerance 1e-3

Runs ``problem.solve(tolerance=...)`` once under cProfile and prints: wall and CPU of the whole call;
per refinement the mesh (intervals x points, degrees), the IPOPT iterations and CPU of the solution and
of its companion, the estimate (states / multipliers), the splits at located switches
(:mod:`ocp_constraints.ocp.switch_detection`); then the functions by cumulative time (IPOPT's share is
``Function_call``; the transcription builds are ``_build``). The walker at 1e-4 (load ~10): 95% in
IPOPT, 4% in builds, 11 solves of 15-22 iterations each.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import time


def _problem(name: str):
    """A suite problem in its pinned coordinates, or one of the bench's switching cases."""
    if name == "minimum-time swing-up":
        from ocp_constraints.bench.mesh_refinement import minimum_time_swing_up

        return minimum_time_swing_up()
    if name == "rolling_disk drive":
        from ocp_constraints.bench.mesh_refinement import _task

        return _task("rolling_disk", "drive")
    from ocp_constraints.bench.ocp_suite_run import PROBLEMS

    sp = next((p for p in PROBLEMS if p.name == name), None)
    if sp is None:
        raise SystemExit(f"unknown problem {name!r}: one of {[p.name for p in PROBLEMS]}, "
                         f"'minimum-time swing-up', 'rolling_disk drive'")
    return sp.ours(coordinates=sp.fine_coordinates)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("problem")
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--top", type=int, default=25, help="functions printed by cumulative time")
    args = ap.parse_args(argv)
    problem = _problem(args.problem)
    profile = cProfile.Profile()
    wall, cpu = time.perf_counter(), time.process_time()
    profile.enable()
    sol = problem.solve(tolerance=args.tolerance, progress=False)
    profile.disable()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    mr = sol.mesh_refinement
    print(f"{args.problem} tolerance {args.tolerance:g}: {wall:.1f} s wall, {cpu:.1f} s CPU; met {mr['met']}: {mr['message']}")
    for h in mr["history"]:
        est = h.get("estimate", {})
        print(f"  refinement {h['refinement']}: {h['intervals']} x {h['points']} points, degrees "
              f"{min(h['degrees'])}-{max(h['degrees'])}; IPOPT iterations {h.get('iterations')} + "
              f"{h.get('companion_iterations', '-')}, CPU {h.get('cpu_s', 0):.1f} + {h.get('companion_cpu_s', 0):.1f} s; "
              f"estimate states {est.get('states', float('nan')):.1e}, multipliers {est.get('multipliers', float('nan')):.1e}; "
              f"split at {len(h.get('switches', []))} switch(es)")
    pstats.Stats(profile).sort_stats("cumulative").print_stats(args.top)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
