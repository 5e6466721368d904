"""``ocp-constraints bench``: work-precision benchmarks (arguments; the bench is imported only when run)."""
from __future__ import annotations

from ..bench.defaults import DEFAULT_OUT, QUICK_SCENES
from .help import HelpFormatter, example


def cli_bench(args) -> int:
    if args.ocp_suite:
        from ..bench.ocp_suite_run import run_suite
        from ..errors import SceneError

        if args.runs < 1 or args.ocp_n < 1:
            raise SceneError(f"bench --ocp-suite: --runs and --ocp-n must be at least 1, got {args.runs} and {args.ocp_n}")
        rows = run_suite(args.out, runs=args.runs, N=args.ocp_n, only=args.only, readme=args.readme,
                         fine_mesh=tuple(args.ocp_fine) if args.ocp_fine else None, coordinates=tuple(args.ocp_coordinates))
        return 0 if all(r["ours_success"] and r["fine_success"] for r in rows) else 1
    from ..bench.report import run_bench

    return run_bench(args)


def add_bench_parser(subparsers) -> None:
    b = subparsers.add_parser("bench", help="work-precision benchmarks, peers side by side, scaling and stress cases",
                              description="Work-precision sweeps of every scene against independent references, the "
                                          "optional peers (rockit, Drake, Pinocchio, sympy) side by side, scaling and "
                                          "stress cases; tables and plots into --out.",
                              epilog=example("ocp-constraints bench --quick"), formatter_class=HelpFormatter)
    b.add_argument("scenes", nargs="*", help="scenes (default: all; --quick: " + ", ".join(QUICK_SCENES) + ")")
    b.add_argument("--quick", action="store_true",
                   help="a small subset: about 40 s on an idle machine (41 s of CPU measured)")
    b.add_argument("--target-error", type=float, default=1e-6, metavar="E", help="error to reach (default 1e-6)")
    b.add_argument("--out", default=DEFAULT_OUT, metavar="DIR", help=f"results folder (default {DEFAULT_OUT})")
    b.add_argument("--runs", type=int, default=3, metavar="N", help="runs per setting, median kept (default 3, at least 3)")
    b.add_argument("--no-scaling", action="store_true", help="skip the scaling and slow stress runs")
    b.add_argument("--readme", metavar="PATH", help="also write the report into PATH between its bench markers")
    b.add_argument("--ocp-suite", action="store_true",
                   help="the user-problem OCP suite instead (acrobot, cart_double_pendulum, four_bar, rolling_disk, "
                        "quadrotor_load, walker): ours, ours in joint coordinates and rockit, against minimal-coordinate "
                        "references; ocp_suite.csv, ocp_suite.chain.csv and .md into --out (--runs: here at least 1)")
    b.add_argument("--only", nargs="+", metavar="NAME", help="with --ocp-suite: only these problems")
    b.add_argument("--ocp-n", type=int, default=20, metavar="N", help="with --ocp-suite: intervals of the timed solves (default 20)")
    b.add_argument("--ocp-coordinates", nargs="+", choices=("maximal", "joint"), default=["maximal", "joint"],
                   metavar="KIND", help="with --ocp-suite: our runs: maximal, and with joint also in joint coordinates "
                                        "(default both; maximal always runs)")
    b.add_argument("--ocp-fine", type=int, nargs=2, metavar=("N", "DEGREE"),
                   help="with --ocp-suite: the accuracy chain (ours and the reference) on N, 2N and 4N intervals of "
                        "this degree for every problem (default: each problem's own chain, Radau 7 with N doubling "
                        "until the reference has converged)")
    b.set_defaults(handler=cli_bench)
