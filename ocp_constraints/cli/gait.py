"""``ocp-constraints gait``: inverse dynamics of a measured gait trial (arguments and handler)."""
from __future__ import annotations

import sys

from ..errors import OcpConstraintsError


def add_gait_parser(subparsers) -> None:
    """``gait --model M.osim --motion IK --grf GRF [--side right] [--start T0 --end T1] --out DIR``."""
    g = subparsers.add_parser("gait", help="inverse dynamics of a gait trial: joint loads by Lagrange's prescription")
    g.add_argument("--model", required=True, help="OpenSim model (.osim, 4.x format)")
    g.add_argument("--motion", required=True, help="joint coordinates (IK .mot/.sto, JW .csv/.mat)")
    g.add_argument("--grf", required=True, help="ground reaction forces (.mot/.sto/.csv/.mat, any number of plates)")
    g.add_argument("--side", choices=("right", "left"), default="right", help="leg whose joints are reported")
    g.add_argument("--start", type=float, default=None, help="first time [s] (default: start of the motion)")
    g.add_argument("--end", type=float, default=None, help="last time [s] (default: end of the motion)")
    g.add_argument("--cutoff", type=float, default=6.0, help="low-pass cutoff of the coordinates [Hz] (default 6)")
    g.add_argument("--out", required=True, help="folder for summary.json, loads.csv and plots")
    g.add_argument("--no-plots", action="store_true", help="write no PNG plots")
    g.set_defaults(handler=cli_gait)


def cli_gait(args) -> int:
    """Run ``gait``; errors in the input print one line and return 2."""
    from ..biomech.gait import run_inverse_dynamics
    from ..biomech.gait_report import write_gait_results

    try:
        result = run_inverse_dynamics(args.model, args.motion, args.grf, args.start, args.end,
                                      args.cutoff if args.cutoff and args.cutoff > 0 else None)
        summary = write_gait_results(result, args.out, args.side, plots=not getattr(args, "no_plots", False),
                                     inputs={"model": args.model, "motion": args.motion, "grf": args.grf})
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"gait: {summary['samples']} samples {summary['t_start']:g} ... {summary['t_end']:g} s, "
          f"plates {summary['plates']}, inverse dynamics in {result.timings['total']:.2f} s; results in {args.out}")
    return 0
