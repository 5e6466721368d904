"""``ocp-constraints knee``: knee contact loads of a gait trial (arguments and handler)."""
from __future__ import annotations

import os
import sys

from ..biomech.knee_options import METHOD_DEFAULT, METHOD_TEXT, METHODS, MUSCLE_MODELS, PASSIVE_DEFAULT, PASSIVE_HIP, QUADRICEPS, QUADRICEPS_DEFAULT
from ..errors import OcpConstraintsError
from .gait import print_data_notes
from .interruption import write_if_interrupted
from .help import JW_MODEL, JW_TRIAL, HelpFormatter, example


def add_knee_parser(subparsers) -> None:
    """``knee --model M.osim --motion IK --grf GRF [--measured KCF] [--method static|collocation] --out DIR``."""
    k = subparsers.add_parser("knee", help="knee contact loads (condyle contact, minimum-effort muscle forces)",
                              description="Medial and lateral knee contact forces over the right gait cycle: inverse "
                                          "dynamics, then minimum-effort muscle forces with the condyle contacts as "
                                          "constraints; compared with measured loads if given. Writes summary.json, "
                                          "loads.csv/.sto, muscle_forces.sto, trajectory.sto, knee_contact.png and "
                                          "report.html into --out.",
                              epilog=example("ocp-constraints knee", f"--model {JW_MODEL}",
                                             f"--motion {JW_TRIAL}/IK/IK_ngait_og5.mat",
                                             f"--grf {JW_TRIAL}/GRF/GRF_ngait_og5.mat",
                                             f"--measured {JW_TRIAL}/KCF/KCF_ngait_og5.mat", "--out results/knee"),
                              formatter_class=HelpFormatter)
    k.add_argument("--model", required=True, metavar="MODEL.osim", help="OpenSim model with a JW-type 6-DOF knee (.osim)")
    k.add_argument("--motion", required=True, metavar="FILE", help="joint coordinates (IK .mot/.sto/.csv/.mat)")
    k.add_argument("--grf", required=True, metavar="FILE", help="ground reaction forces (.mot/.sto/.csv/.mat)")
    k.add_argument("--measured", default=None, metavar="FILE", help="measured contact forces (KCF .csv/.mat: PM, AM, AL, PL in lbf)")
    k.add_argument("--method", choices=METHODS, default=METHOD_DEFAULT,
                   help="collocation: first-order activation dynamics over the whole cycle (default); static: "
                        "per-frame static optimisation (the fast-activation limit, about 3x faster)")
    k.add_argument("--muscle-model", choices=MUSCLE_MODELS, default="ideal",
                   help="ideal: F = a F0 (default); hill: De Groote et al. 2016 force-length-velocity curves "
                        "with a rigid tendon (experimental: its passive quadriceps forces are unphysical in swing); "
                        "the fibres' passive force counts as part of --passive's measured moments, not on top")
    f = k.add_mutually_exclusive_group()
    f.add_argument("--cutoff", type=float, default=6.0,
                   help="low-pass cutoff of the coordinates [Hz], 0 < cutoff < the motion's Nyquist frequency (default 6)")
    f.add_argument("--no-filter", action="store_true", help="use the coordinates unfiltered (no low-pass)")
    k.add_argument("--passive", "--passive-hip", dest="passive_hip", choices=PASSIVE_HIP, default=PASSIVE_DEFAULT,
                   metavar="MODEL",
                   help="passive moments taken off the muscles' share (Riener & Edrich 1999, in vivo, all passive "
                        "structures): riener-edrich-1999-hip-knee-ankle the hip's, knee's and ankle's (default), "
                        "riener-edrich-1999 the hip's only; none: muscles carry the whole net moments")
    k.add_argument("--quadriceps", choices=QUADRICEPS, default=QUADRICEPS_DEFAULT,
                   help="the quadriceps' pull on the tibia: patellar-ligament (default), the vasti along the central "
                        "patellar ligament line on the locked knee directions (issue 15, C13); model-paths, each "
                        "head's own path in the model file")
    k.add_argument("--implant-meshes", default=None, metavar="DIR",
                   help="folder with the implant's contact meshes (femPoints_188.csv, tibPoints_100.csv, "
                        "facesTib1_100.csv, facesTib2_100.csv): needed once for a model other than the JW model")
    k.add_argument("--out", required=True, metavar="DIR",
                   help="folder for summary.json, loads.csv/.sto, muscle_forces.sto, plots and report.html")
    k.add_argument("--no-plots", action="store_true", help="write no PNG plots and no report.html")
    k.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="replace a condyle centre of the implant geometry (m, femoral component frame): "
                        "medial_cx/cy/cz, lateral_cx/cy/cz (condyle spacing = medial_cz - lateral_cz)")
    k.set_defaults(handler=cli_knee)


def cli_knee(args) -> int:
    """Run ``knee``; input errors print one line and return 2."""
    # the per-sample systems are small (about 150 unknowns): BLAS threads only contend (measured:
    # inverse dynamics of ngait_og5 30 s -> 5 s on the loaded 2-core machine); set before NumPy loads
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from ..biomech.knee_pipeline import run_knee, write_knee_results
    from ..output.files import check_output_folder

    from ..output.signals import signal_mark

    mark = signal_mark()
    figures = None
    if not args.no_plots:       # matplotlib loads in a second process while this one computes
        from ..output.drawing_process import DrawingProcess

        figures = DrawingProcess(warm=_warm_figure)
    try:
        check_output_folder(args.out)       # an --out that cannot be written fails now, not after the computing
        cutoff = None if getattr(args, "no_filter", False) else getattr(args, "cutoff", 6.0)
        run = run_knee(args.model, args.motion, args.grf, args.measured, muscle_model=args.muscle_model,
                       method=args.method, cutoff=cutoff, implant_meshes=getattr(args, "implant_meshes", None),
                       passive_hip=getattr(args, "passive_hip", PASSIVE_DEFAULT),
                       quadriceps=getattr(args, "quadriceps", QUADRICEPS_DEFAULT),
                       parameters=_params(getattr(args, "param", [])))
        summary = write_knee_results(run, args.out, plots=not args.no_plots, figure_process=figures,
                                     inputs={"model": str(args.model), "motion": str(args.motion), "grf": str(args.grf),
                                             "measured": None if args.measured is None else str(args.measured),
                                             "method": args.method, "muscle_model": args.muscle_model,
                                             "cutoff_hz": cutoff, "no_filter": cutoff is None,
                                             "passive_hip": getattr(args, "passive_hip", PASSIVE_DEFAULT),
                                             "parameters": {k: float(v) for k, v in
                                                            _params(getattr(args, "param", [])).items()}})
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except BaseException as exc:   # SIGINT/SIGTERM before the results were complete: say so in --out
        stop = write_if_interrupted(exc, mark, args.out, "knee contact loads", args)
        if stop is None:
            raise
        raise stop from None
    finally:
        if figures is not None:
            figures.close()
    print_data_notes(summary)
    if summary.get("fallback"):
        print(f"warning: {summary['fallback']}", file=sys.stderr)
    if not summary["success"]:      # IPOPT failed: its last iterate is written, marked so (DESIGN.md: exit 1)
        print(f"error: IPOPT did not solve the muscle forces (status '{summary['status']}'); its last iterate is "
              f"written to {args.out} with \"success\": false", file=sys.stderr)
        return 1
    w = summary["wall_time_s"]
    print(f"knee: cycle {summary['gait_cycle_s'][0]:g}-{summary['gait_cycle_s'][1]:g} s, {summary['frames']} frames, "
          f"{METHOD_TEXT[summary['method']]} {w['build'] + w['solve']:.2f} s; results in {args.out}")
    if summary["comparison"]:
        compared = next(iter(summary["comparison"].values()))["frames_compared"]
        if compared < summary["frames"]:
            print(f"note: the measured loads cover {compared} of the cycle's {summary['frames']} frames; only those "
                  f"are compared", file=sys.stderr)
        for k, v in summary["comparison"].items():
            print(f"  {k}: RMSE {v['rmse_bw']:.2f} BW, r {v['r']:.2f}, R^2 {v.get('r2', float('nan')):.2f}, "
                  f"peak error {v['peak_error_bw']:+.2f} BW")
    return 0


def _warm_figure() -> None:
    """In the drawing process: a knee figure drawn once ahead (imported there, not before the fork)."""
    from ..output.joint_plots import warm_knee_figure

    warm_knee_figure()


def _params(items: list[str]) -> dict[str, str]:
    from ..scenes.registry import parse_param_arguments

    return parse_param_arguments(items)
