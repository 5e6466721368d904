"""The ``ocp-constraints`` command.

    ocp-constraints list
    ocp-constraints simulate SCENE [--t-final T] [--dt DT] [--out DIR] [--param name=value ...] [--no-plots]
    ocp-constraints solve SCENE [--task NAME] [--scheme trapezoidal|hermite-simpson|radau] [--degree D]
                          [--intervals N] [--out DIR] [--param name=value ...] [--no-plots]
    ocp-constraints export-c SCENE --out DIR [--param name=value ...] [--no-verify]
    ocp-constraints bench-export [SCENE ...] [--runs N] [--markdown [PATH]]
    ocp-constraints gait --model MODEL.osim --motion IK --grf GRF [--side right] [--start T0 --end T1] --out DIR
    ocp-constraints knee --model MODEL.osim --motion IK --grf GRF [--measured KCF] [--muscle-model hill|ideal] --out DIR
    ocp-constraints bench [SCENE ...] [--quick] [--target-error E] [--out DIR]

SCENE is a built-in scene name (see ``list``) or the path of a scene file. Errors in
the input are reported in one line naming the culprit, with exit status 2; a
simulation that stops early writes what it computed (``"success": false``) and exits 1.
"""
from __future__ import annotations

import argparse
import sys

from .errors import OcpConstraintsError, SimulationError


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="ocp-constraints", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the built-in scenes").set_defaults(handler=lambda args: _list())
    s = sub.add_parser("simulate", help="forward simulation with constraint loads")
    s.add_argument("scene", help="built-in scene name or path of a scene file")
    s.add_argument("--t-final", type=float, default=None, help="end time [s] (default: the scene's)")
    s.add_argument("--dt", type=float, default=0.01, help="output sampling [s] (default 0.01)")
    s.add_argument("--out", default=None, help="folder for summary.json, trajectory.csv, loads.csv and plots")
    s.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="override a scene parameter")
    s.add_argument("--no-plots", action="store_true", help="write no PNG plots")
    s.set_defaults(handler=_simulate)
    o = sub.add_parser("solve", help="optimal control by direct collocation and IPOPT")
    o.add_argument("scene", help="built-in scene name or path of a scene file")
    o.add_argument("--task", default=None, help="task of the scene (default: its first)")
    o.add_argument("--scheme", default="radau", choices=["trapezoidal", "hermite-simpson", "radau"])
    o.add_argument("--degree", type=int, default=3, help="Radau degree, 1 to 9 (default 3)")
    o.add_argument("--intervals", type=int, default=50, help="mesh intervals (default 50)")
    o.add_argument("--out", default=None, help="folder for summary.json, trajectory.csv, loads.csv and plots")
    o.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="override a scene parameter")
    o.add_argument("--no-plots", action="store_true", help="write no PNG plots")
    o.add_argument("--reintegrate", action="store_true", help="forward-simulate the optimal inputs and report the deviation")
    o.set_defaults(handler=_solve)
    from .bench import add_bench_parser
    from .export import add_export_parser
    from .gait import add_gait_parser
    from .knee_cli import add_knee_parser

    add_export_parser(sub)
    add_gait_parser(sub)
    add_knee_parser(sub)
    add_bench_parser(sub)
    return p


def _list() -> int:
    from .scenes import builtin_scene_names, load_scene_module

    names = builtin_scene_names()
    width = max(len(n) for n in names)
    for n in names:
        module = load_scene_module(n)
        tasks = getattr(module, "TASKS", {})
        extra = f"  [solve tasks: {', '.join(tasks)}]" if tasks else ""
        print(f"{n:<{width}}  {getattr(module, 'DESCRIPTION', '').strip()}{extra}")
    return 0


def _simulate(args) -> int:
    from .scenes import build_scene, parse_param_arguments
    from .simulate import SimulationOptions
    from .tasks import run_simulation

    scene = build_scene(args.scene, parse_param_arguments(args.param))
    options = SimulationOptions(dt=args.dt)
    try:
        _, summary = run_simulation(scene, args.scene, args.t_final, args.out, options, plots=not args.no_plots)
    except SimulationError as exc:
        print(f"error: simulation stopped early: {exc}", file=sys.stderr)
        if args.out:
            print(f"partial results written to {args.out} (summary.json has \"success\": false)", file=sys.stderr)
        return 1
    res = summary["max_constraint_residual"]
    print(
        f"{args.scene}: simulated {summary['t_reached']:g} s in {summary['wall_time']['solve']:.2f} s; "
        f"max residuals position {res['position']:.2e}, velocity {res['velocity']:.2e}; "
        f"energy balance error {summary['energy']['relative_error']:.2e} (relative)"
    )
    if args.out:
        print(f"results in {args.out}")
    return 0


def _solve(args) -> int:
    from .ocp_solution import OCPSolveError
    from .scenes import build_task, parse_param_arguments
    from .tasks import run_optimal_control
    from .transcription import scheme_from_name

    task, problem = build_task(args.scene, args.task, parse_param_arguments(args.param))
    method = scheme_from_name(args.scheme, args.intervals, args.degree)
    try:
        sol, summary = run_optimal_control(problem, args.scene, task, method, args.out, plots=not args.no_plots,
                                           reintegrate=args.reintegrate)
    except OCPSolveError as exc:
        print(f"error: {exc}", file=sys.stderr)
        if args.out:
            print(f"last iterate written to {args.out} (summary.json has \"success\": false)", file=sys.stderr)
        return 1
    res = summary["max_constraint_residual"]
    print(
        f"{args.scene} {task}: {summary['status']} in {sol.iterations} iterations, objective {sol.objective:.10g}; "
        f"build {summary['wall_time']['build']:.2f} s, solve {summary['wall_time']['solve']:.3f} s; "
        f"max residuals position {res['position']:.1e}, velocity {res['velocity']:.1e}"
    )
    for joint, work in summary["joint_work"].items():
        if abs(work) > 1e-9:
            print(f"  work done by joint '{joint}': {work:.6g} J")
    if "reintegration" in summary:
        print(f"  re-integration of the optimal inputs: max state deviation {summary['reintegration']['max_state_deviation']:.2e}")
    if args.out:
        print(f"results in {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return args.handler(args)
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
