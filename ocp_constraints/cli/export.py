"""``ocp-constraints export-c`` and ``bench-export``: C export of a scene (arguments and handlers)."""
from __future__ import annotations

import argparse

from .help import HelpFormatter, example


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def add_export_parser(subparsers) -> None:
    """Add ``export-c`` and ``bench-export`` to an argparse ``subparsers`` object.

    Each sets ``handler`` (:func:`cli_export_c`, :func:`cli_bench_export`); a handler
    returns the exit status and raises :class:`OcpConstraintsError` on bad input.
    """
    e = subparsers.add_parser("export-c", help="export the scene's constraint functions as C (CasADi codegen)",
                              description="Generate plain C for a scene's constraint residuals, gradients, loads and "
                                          "inverse-dynamics multipliers, with a header, an example program, a Makefile "
                                          "and a CMakeLists.txt; compiled and checked against CasADi unless --no-verify.",
                              epilog=example("ocp-constraints export-c whirling", "--out results/export/whirling"),
                              formatter_class=HelpFormatter)
    e.add_argument("scene", help="built-in scene name or path of a scene file")
    e.add_argument("--out", required=True, metavar="DIR", help="folder to write (an earlier export there is replaced)")
    e.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="override a scene parameter")
    e.add_argument("--no-verify", action="store_true", help="do not compile and check the round trip")
    e.set_defaults(handler=cli_export_c)
    b = subparsers.add_parser("bench-export", help="evaluations per second of the exported multipliers",
                              description="Time the exported C multipliers against CasADi's own evaluation.")
    b.add_argument("scenes", nargs="*", metavar="SCENE", help="scenes (default: whirling rolling_disk)")
    b.add_argument("--runs", type=_positive_int, default=5, metavar="N",
                   help="timed runs per method; the median is reported (default 5)")
    b.add_argument("--markdown", nargs="?", const="results/export/bench.md", default=None, metavar="PATH",
                   help="also write the table as Markdown (default path results/export/bench.md)")
    b.set_defaults(handler=cli_bench_export)


def cli_export_c(args) -> int:
    """``export-c SCENE --out DIR [--param name=value ...] [--no-verify]``: one summary line."""
    from ..scenes.registry import parse_param_arguments

    from ..codegen.export import export_c

    report = export_c(args.scene, args.out, parse_param_arguments(args.param), verify=not args.no_verify)
    mult = report.function("multipliers")
    line = (f"{report.scene}: {len(report.functions)} functions, {report.code_bytes} bytes / {report.code_lines} "
            f"lines of C in {report.out_dir}; multipliers {mult.n_operations} operations")
    rt = report.round_trip
    if rt is None:
        line += "; not compiled (--no-verify)"
    else:
        line += (f"; round trip on {rt.n_states} random states: max relative error {rt.max_error:.1e} "
                 f"(<= {rt.tolerance:g}), example output matches")
    print(line)
    return 0


def cli_bench_export(args) -> int:
    """``bench-export [SCENE ...] [--runs N] [--markdown [PATH]]``: one summary line."""
    from ..bench.export_speed import DEFAULT_SCENES, benchmark_export

    rows = benchmark_export(tuple(args.scenes) or DEFAULT_SCENES, runs=args.runs, markdown=args.markdown)
    parts: dict[str, list[str]] = {}
    for r in rows:
        parts.setdefault(r.scene, []).append(f"{r.method.split(',')[0]} {r.evals_per_s:.3g}/s")
    line = "; ".join(f"{s}: " + ", ".join(v) for s, v in parts.items())
    print(f"multipliers evaluations per second (median of {args.runs}): {line}"
          + (f"; table in {args.markdown}" if args.markdown else ""))
    return 0
