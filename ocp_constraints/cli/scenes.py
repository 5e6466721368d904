"""``list``, ``simulate`` and ``solve``: the commands that run a built-in or user scene."""
from __future__ import annotations

import sys

from .help import HelpFormatter, example


def add_scene_parsers(sub) -> None:
    """Register ``list``, ``simulate`` and ``solve`` (their handlers import the library only when run)."""
    sub.add_parser("list", help="list the built-in scenes and their optimal-control tasks",
                   description="List the built-in scenes, what each shows, and their optimal-control tasks.").set_defaults(
        handler=lambda args: _list())
    s = sub.add_parser("simulate", help="forward simulation with constraint loads",
                       description="Simulate a scene forward in time (CVODES, projection onto the constraints) and "
                                   "report every joint's constraint force, moment and power. With --out: "
                                   "summary.json, trajectory.csv/.sto, loads.csv/.sto, PNG plots and report.html.",
                       epilog=example("ocp-constraints simulate whirling", "--t-final 10",
                                      "--param omega_amplitude=0.5", "--out results/whirling"),
                       formatter_class=HelpFormatter)
    s.add_argument("scene", help="built-in scene name or path of a scene file")
    s.add_argument("--t-final", type=float, default=None, metavar="T", help="end time [s] (default: the scene's)")
    s.add_argument("--dt", type=float, default=0.01, metavar="DT", help="output sampling [s] (default 0.01)")
    s.add_argument("--out", default=None, metavar="DIR", help="folder for summary.json, trajectory.csv/.sto, loads.csv/.sto, plots and report.html (default: none written)")
    s.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="override a scene parameter")
    s.add_argument("--no-plots", action="store_true", help="write no PNG plots and no report.html")
    s.set_defaults(handler=_simulate)
    o = sub.add_parser("solve", help="optimal control by direct collocation and IPOPT",
                       description="Solve an optimal-control task of a scene by direct collocation and IPOPT; the "
                                   "constraint loads come with the solution. With --out: the files of simulate.",
                       epilog=example("ocp-constraints solve pendulum", "--scheme radau --degree 3 --intervals 50",
                                      "--out results/swing_up"),
                       formatter_class=HelpFormatter)
    o.add_argument("scene", help="built-in scene name or path of a scene file")
    o.add_argument("--task", default=None, metavar="NAME", help="task of the scene (default: its first; see 'list')")
    o.add_argument("--scheme", default="radau", choices=["trapezoidal", "hermite-simpson", "radau"],
                   help="collocation scheme (default radau)")
    o.add_argument("--degree", type=int, default=None, metavar="D",
                   help="Radau degree, 1 to 9 (default 3; with --tolerance, of the starting mesh: default 5; --scheme radau only)")
    o.add_argument("--intervals", type=int, default=None, metavar="N",
                   help="mesh intervals (default 50; with --tolerance, of the starting mesh: default 10)")
    o.add_argument("--out", default=None, metavar="DIR", help="folder for summary.json, trajectory.csv/.sto, loads.csv/.sto, plots and report.html (default: none written)")
    o.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="override a scene parameter")
    o.add_argument("--no-plots", action="store_true", help="write no PNG plots and no report.html")
    o.add_argument("--reintegrate", action="store_true", help="forward-simulate the optimal inputs and report the deviation")
    o.add_argument("--starts", type=int, default=1, metavar="K",
                   help="multi-start: solve from K guesses (the task's and K-1 perturbed), keep the best, "
                        "report the local optima (default 1)")
    o.add_argument("--seed", type=int, default=0, metavar="S", help="seed of the --starts perturbations (default 0)")
    o.add_argument("--tolerance", type=float, default=None, metavar="TOL",
                   help="hp mesh refinement until the estimated error is at most TOL (states in SI units, "
                        "multipliers relative to the largest load), starting from --intervals N (default 10 "
                        "here) of --degree D (default 5 here, as problem.solve(tolerance=...)); summary.json gets the final "
                        "mesh, the estimates and the history")
    o.add_argument("--max-refinements", type=int, default=None, metavar="R",
                   help="with --tolerance: refinements after the first solve at most (default 10)")
    o.add_argument("--ipopt", action="append", default=[], metavar="NAME=VALUE",
                   help="an IPOPT option for every solve, e.g. --ipopt max_iter=500 or --ipopt compl_inf_tol=1e-13 (repeatable; "
                        "recorded in summary.json; names at https://coin-or.github.io/Ipopt/OPTIONS.html)")
    o.add_argument("--coordinates", default="auto", choices=["auto", "maximal", "joint", "condensed"],
                   help="NLP coordinates: every body's (maximal) or the joints' (joint: bodies on revolute, "
                        "prismatic and weld joints placed by their joint coordinates; same results files); "
                        "condensed: every body's, accelerations and multipliers from each point's KKT system; "
                        "auto (default): joint where bodies hang on such joints in no closed chain")
    o.set_defaults(handler=_solve)


def _list() -> int:
    from ..scenes.registry import builtin_scene_names, load_scene_module

    names = builtin_scene_names()
    width = max(len(n) for n in names)
    for n in names:
        module = load_scene_module(n)
        tasks = getattr(module, "TASKS", {})
        extra = f"  [solve tasks: {', '.join(tasks)}]" if tasks else ""
        print(f"{n:<{width}}  {getattr(module, 'DESCRIPTION', '').strip()}{extra}")
    return 0


def _simulate(args) -> int:
    from ..errors import SimulationError
    from ..scenes.registry import build_scene, parse_param_arguments
    from ..dynamics.simulate import SimulationOptions
    from ..scenes.tasks import run_simulation

    scene = build_scene(args.scene, parse_param_arguments(args.param))
    options = SimulationOptions(dt=args.dt)

    def started(info: dict) -> None:   # one line before the integration: what the run will cost
        print(f"simulating {args.scene}: t = {info['t0']:g} ... {info['t_final']:g} s, {info['samples']:,} samples, "
              f"about {info['memory_bytes'] / 1e6:.3g} MB", file=sys.stderr, flush=True)

    try:
        _, summary = run_simulation(scene, args.scene, args.t_final, args.out, options, plots=not args.no_plots,
                                    on_start=started)
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


def ipopt_arguments(pairs: list[str]) -> dict:
    """``--ipopt NAME=VALUE`` pairs as nlpsol options (``ipopt.NAME``): integers and numbers as such, other values as text."""
    from ..errors import UsageError

    out = {}
    for pair in pairs:
        name, sep, value = (part.strip() for part in pair.partition("="))
        if not (sep and name and value):
            raise UsageError(f"--ipopt {pair!r}: give NAME=VALUE, e.g. --ipopt max_iter=500 or --ipopt compl_inf_tol=1e-13")
        for kind in (int, float):
            try:
                value = kind(value)
                break
            except ValueError:
                continue
        out[name if name.startswith("ipopt.") else f"ipopt.{name}"] = value
    return out


def _solve(args) -> int:
    from ..errors import OCPSolveError
    from ..scenes.registry import build_task, parse_param_arguments
    from ..scenes.tasks import run_optimal_control
    from ..ocp.schemes import scheme_from_name
    from ..ocp.mesh_refinement import START

    from ..errors import UsageError

    if args.degree is not None and args.scheme != "radau":
        raise UsageError(f"--degree {args.degree} applies to --scheme radau only; {args.scheme} has a fixed order. "
                         "Drop --degree, or use --scheme radau")
    tolerance = getattr(args, "tolerance", None)
    if tolerance is not None and args.scheme != "radau":
        raise UsageError(f"--tolerance refines Radau meshes (degrees and intervals); {args.scheme} has a fixed order. "
                         "Drop --scheme, or drop --tolerance")
    if tolerance is not None and not 0 < tolerance < float("inf"):
        raise UsageError(f"--tolerance must be a positive number such as 1e-6, got {tolerance!r}")
    if getattr(args, "max_refinements", None) is not None and tolerance is None:
        raise UsageError(f"--max-refinements {args.max_refinements} applies with --tolerance only (mesh refinement); "
                         f"add --tolerance TOL, or drop --max-refinements")
    ipopt_options = ipopt_arguments(getattr(args, "ipopt", []))
    task, problem = build_task(args.scene, args.task, parse_param_arguments(args.param))
    problem.coordinates = getattr(args, "coordinates", "auto")
    # With --tolerance the starting mesh defaults to the library's (START), so the command and
    # problem.solve(tolerance=...) refine the same meshes.
    default = {"intervals": 50, "degree": 3} if tolerance is None else START
    intervals = args.intervals if args.intervals is not None else default["intervals"]
    method = scheme_from_name(args.scheme, intervals, default["degree"] if args.degree is None else args.degree)
    try:
        sol, summary = run_optimal_control(problem, args.scene, task, method, args.out, ipopt_options, plots=not args.no_plots,
                                           reintegrate=args.reintegrate, starts=getattr(args, "starts", 1),
                                           seed=getattr(args, "seed", 0), tolerance=tolerance,
                                           max_refinements=getattr(args, "max_refinements", None))
    except OCPSolveError as exc:
        print(f"error: {exc}", file=sys.stderr)
        if args.out:
            print(f"last iterate written to {args.out} (summary.json has \"success\": false)", file=sys.stderr)
        return 1
    res = summary["max_constraint_residual"]
    print(
        f"{args.scene} {task}: {summary['status']} in {sol.iterations} iterations"
        + (f" (the last of {summary['solves']} solves, {summary['iterations']} iterations in all)" if "solves" in summary else "")
        + f", objective {sol.objective:.10g}; "
        f"build {summary['wall_time']['build']:.2f} s, solve {summary['wall_time']['solve']:.3f} s; "
        f"max residuals position {res['position']:.1e}, velocity {res['velocity']:.1e}"
    )
    for joint, work in summary["joint_work"].items():
        if abs(work) > 1e-9:
            print(f"  work done by joint '{joint}': {work:.6g} J")
    if "multistart" in summary:
        ms = summary["multistart"]
        optima = ", ".join(f"{o['objective']:.8g} (x{o['count']})" for o in ms["optima"])
        print(f"  {ms['succeeded']} of {ms['starts']} starts solved (seed {ms['seed']}); local optima: {optima}")
    if "mesh_refinement" in summary:
        mr = summary["mesh_refinement"]
        est = ("estimated error " + ", ".join(f"{q} {v:.1e}" for q, v in mr["estimate"].items()) if mr["estimate"]
               else "error NOT estimated")
        print(f"  mesh refinement to {mr['tolerance']:g}: {'met' if mr['met'] else 'NOT met'} after {mr['refinements']} "
              f"refinements, {len(mr['degrees'])} intervals of degrees {min(mr['degrees'])}-{max(mr['degrees'])}; "
              f"{est}; {mr['total_time_s']:.2f} s in all")
        if "complementarity_tolerance" in mr:   # mesh_solves.complementarity_tolerance: bounds reached, tol <= 1e-4
            unscaled = " with MUMPS's scaling off" if mr.get("mumps_scaling") == 0 else ""
            print(f"  IPOPT's complementarity held to {mr['complementarity_tolerance']:.0e} in the warm solves{unscaled} "
                  f"(bounds or path constraints are reached)")
        if not mr["met"]:       # why: the estimate above the tolerance, or not trusted at a switch (intervals named)
            print(f"  {mr['message']}")
    if "reintegration" in summary:
        print(f"  re-integration of the optimal inputs: max state deviation {summary['reintegration']['max_state_deviation']:.2e}")
    if args.out:
        print(f"results in {args.out}")
    return 0
