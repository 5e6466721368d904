"""``ocp-constraints gait``: inverse dynamics of a measured gait trial (arguments and handler)."""
from __future__ import annotations

import os
import sys

from ..errors import OcpConstraintsError
from .interruption import write_if_interrupted
from .help import GAIT, HelpFormatter, example


def add_gait_parser(subparsers) -> None:
    """``gait --model M.osim --motion IK --grf GRF [--side right] [--start T0 --end T1] --out DIR``."""
    g = subparsers.add_parser("gait", help="inverse dynamics of a gait trial: joint loads by Lagrange's prescription",
                              description="Inverse dynamics of a measured gait trial on an OpenSim model: every joint's "
                                          "constraint force and moment and the generalized force of every coordinate. "
                                          "Writes summary.json, loads.csv/.sto, trajectory.sto (the filtered "
                                          "coordinates, for OpenSim), PNG plots and report.html into --out.",
                              epilog=example("ocp-constraints gait", f"--model {GAIT}/subject01_simbody.osim",
                                             f"--motion {GAIT}/subject01_walk1_ik.mot",
                                             f"--grf {GAIT}/subject01_walk1_grf.mot", "--out results/gait"),
                              formatter_class=HelpFormatter)
    g.add_argument("--model", required=True, metavar="MODEL.osim", help="OpenSim model (.osim, 4.x format)")
    g.add_argument("--motion", required=True, metavar="FILE", help="joint coordinates (IK .mot/.sto, JW .csv/.mat)")
    g.add_argument("--grf", required=True, metavar="FILE",
                   help="ground reaction forces (.mot/.sto/.csv/.mat, any number of plates)")
    g.add_argument("--side", choices=("right", "left"), default="right",
                   help="leg whose joints are reported (default right)")
    g.add_argument("--start", type=float, default=None, metavar="T0", help="first time [s] (default: start of the motion)")
    g.add_argument("--end", type=float, default=None, metavar="T1", help="last time [s] (default: end of the motion)")
    f = g.add_mutually_exclusive_group()
    f.add_argument("--cutoff", type=float, default=6.0,
                   help="low-pass cutoff of the coordinates [Hz], 0 < cutoff < the motion's Nyquist frequency (default 6)")
    f.add_argument("--no-filter", action="store_true", help="use the coordinates unfiltered (no low-pass)")
    g.add_argument("--out", required=True, metavar="DIR",
                   help="folder for summary.json, loads.csv/.sto, trajectory.sto, plots and report.html")
    g.add_argument("--no-plots", action="store_true", help="write no PNG plots and no report.html")
    g.add_argument("--compiled", choices=("auto", "always", "never"), default="auto",
                   help="the model's inverse-dynamics function as compiled C: auto uses a compiled copy when one is "
                        "cached, else runs on CasADi's virtual machine and compiles it in the background for later "
                        "runs; always compiles it now, once per model (about 5 s of CPU for a 24-body model; later "
                        "runs load it); never uses CasADi's virtual machine (default auto)")
    g.set_defaults(handler=cli_gait)


def _warm_figure() -> None:
    """In the drawing process: a gait figure drawn once ahead (imported there, not before the fork)."""
    from ..output.joint_plots import warm_gait_figure

    warm_gait_figure()


def cli_gait(args) -> int:
    """Run ``gait``; errors in the input print one line and return 2."""
    # the per-sample systems are small (about 150 unknowns): BLAS threads only contend (measured:
    # inverse dynamics of ngait_og5 30 s -> 5 s on the loaded 2-core machine); set before NumPy loads
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from ..output.drawing_process import DrawingProcess

    # forked before the heavy imports: it imports matplotlib and draws a first figure while this process computes
    drawer = None if getattr(args, "no_plots", False) else DrawingProcess(warm=_warm_figure)
    from ..biomech.gait import run_inverse_dynamics
    from ..biomech.gait_report import write_gait_results
    from ..output.files import check_output_folder

    from ..output.signals import signal_mark

    mark = signal_mark()
    try:
        check_output_folder(args.out)       # an --out that cannot be written fails now, not after the computing
        cutoff = None if getattr(args, "no_filter", False) else args.cutoff
        result = run_inverse_dynamics(args.model, args.motion, args.grf, args.start, args.end, cutoff,
                                      compiled=getattr(args, "compiled", "auto"))
        summary = write_gait_results(result, args.out, args.side, plots=not getattr(args, "no_plots", False),
                                     inputs={"model": args.model, "motion": args.motion, "grf": args.grf,
                                             "start_s": args.start, "end_s": args.end, "side": args.side,
                                             "cutoff_hz": cutoff, "no_filter": cutoff is None}, drawer=drawer)
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except BaseException as exc:   # SIGINT/SIGTERM before the results were complete: say so in --out
        stop = write_if_interrupted(exc, mark, args.out, "gait inverse dynamics", args)
        if stop is None:
            raise
        raise stop from None
    finally:
        if drawer is not None:
            drawer.close()
    print_data_notes(summary)
    print(f"gait: {summary['samples']} samples {summary['t_start']:g} ... {summary['t_end']:g} s, "
          f"plates {summary['plates']}, inverse dynamics in {result.timings['total']:.2f} s; results in {args.out}")
    return 0


def print_data_notes(summary: dict) -> None:
    """What was done about the data files (time stamps, angle units, columns taken as zero; also in
    summary.json), on stderr."""
    for note in (summary.get("timing") or {}).get("notes", []) + [v for k, v in (summary.get("angles") or {}).items()
                                                                   if k == "angle_unit_note"]:
        print(f"note: {note}", file=sys.stderr)
    for warning in summary.get("warnings") or []:
        print(f"warning: {warning}", file=sys.stderr)
