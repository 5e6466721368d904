"""The ``ocp-constraints`` command: one parser, one subcommand per job, each handler imported when run.

    ocp-constraints list
    ocp-constraints simulate SCENE [--t-final T] [--dt DT] [--out DIR] [--param name=value ...] [--no-plots]
    ocp-constraints solve SCENE [--task NAME] [--scheme trapezoidal|hermite-simpson|radau] [--degree D]
                          [--intervals N] [--out DIR] [--param name=value ...] [--no-plots]
    ocp-constraints export-c SCENE --out DIR [--param name=value ...] [--no-verify]
    ocp-constraints bench-export [SCENE ...] [--runs N] [--markdown [PATH]]
    ocp-constraints gait --model MODEL.osim --motion IK --grf GRF [--side right] [--start T0 --end T1] --out DIR
    ocp-constraints knee --model MODEL.osim --motion IK --grf GRF [--measured KCF] [--muscle-model hill|ideal] --out DIR
    ocp-constraints bench [SCENE ...] [--quick] [--target-error E] [--out DIR]
    ocp-constraints batch SPEC.toml --out DIR [--scheduler ADDRESS] [--workers N] [--resume]

Registering a subcommand imports only argparse code (:mod:`.scenes`, :mod:`.export`, ...); the
library, SciPy and matplotlib are imported by the handler that needs them, so ``--help`` is fast.
Errors in the input are reported in one line naming the culprit, with exit status 2; a run that
stops early writes what it computed (``"success": false``) and exits 1. SIGINT (Ctrl-C) and SIGTERM
take one path (:mod:`ocp_constraints.output.signals`): the run stops, what it computed is written
with ``"status": "interrupted by SIGINT"`` (or SIGTERM), and the exit status is 130 (SIGINT) or
143 (SIGTERM), the shell's convention for a run ended by that signal.
"""
from __future__ import annotations

import argparse
import signal
import sys

from .._version import __version__
from ..errors import OcpConstraintsError, RunInterrupted, interruption_reason
from ..output.signals import interrupt_on_signals, signal_mark, signal_since
from .batch import add_batch_parser
from .bench import add_bench_parser
from .export import add_export_parser
from .gait import add_gait_parser
from .knee import add_knee_parser
from .scenes import add_scene_parsers

DESCRIPTION = ("Constraint forces and constraint moments of rigid bodies by Lagrange's prescription: "
               "simulate, solve optimal control, export C, gait and knee loads, benchmarks.")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="ocp-constraints", description=DESCRIPTION,
                                epilog="SCENE is a built-in scene name (see 'ocp-constraints list') or the path of a "
                                       "scene file. Bad input: one line naming the culprit, exit 2. A run that did not "
                                       "succeed: exit 1, with what it computed written (\"success\": false).")
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_scene_parsers(sub)
    add_export_parser(sub)
    add_gait_parser(sub)
    add_knee_parser(sub)
    add_bench_parser(sub)
    add_batch_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    mark = signal_mark()
    with interrupt_on_signals():
        try:
            return args.handler(args)
        except KeyboardInterrupt as exc:   # SIGINT, or SIGTERM through the same handler
            return _interrupted(exc)
        except Exception as exc:
            if signal_since(mark) is not None:   # the signal surfaced inside NumPy or CasADi as their own error
                return _interrupted(RunInterrupted(signal_since(mark)))
            if isinstance(exc, OcpConstraintsError):
                print(f"error: {exc}", file=sys.stderr)
                return 2
            raise


def _interrupted(exc: BaseException) -> int:
    """One line on what an interrupted run left; the exit status 128 + the signal's number (130, 143)."""
    name = getattr(exc, "signal_name", "SIGINT")
    written = getattr(exc, "written_to", None)
    print(f"{interruption_reason(exc)}: " + (f"the run so far is written to {written} (summary.json has "
          "\"success\": false)" if written else "stopped before any results were written"), file=sys.stderr)
    return 128 + int(getattr(signal, name, signal.SIGINT))
