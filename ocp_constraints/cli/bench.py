"""``ocp-constraints bench``: work-precision benchmarks (arguments; the bench is imported only when run)."""
from __future__ import annotations

from ..bench.defaults import DEFAULT_OUT, QUICK_SCENES
from .help import HelpFormatter, example


def cli_bench(args) -> int:
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
    b.set_defaults(handler=cli_bench)
