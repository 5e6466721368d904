"""The ``ocp-constraints batch`` subcommand: :func:`add_batch_parser` registers it.

    ocp-constraints batch SPEC.toml --out DIR [--scheduler ADDRESS] [--workers N] [--resume] [--no-progress]

Exit status: 0 when every run succeeded (or was skipped by ``--resume``), 1 when some
failed, 2 for bad input (spec, options, unreachable scheduler, Dask missing), 130 after
Ctrl-C (the table then lists the stopped runs as ``cancelled``).
"""
from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import OcpConstraintsError

INSTALL_HINT = 'error: ocp-constraints batch needs Dask: pip install -e ".[batch]"'


def add_batch_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``batch`` to the ``subparsers`` of an argparse parser; returns its parser."""
    b = subparsers.add_parser(
        "batch", help="run many CLI commands (sweeps of a TOML spec) on a Dask cluster",
        description="Run the runs of SPEC (CLI argument templates with sweep variables, expanded as a "
                    "Cartesian product) on Dask. Each run writes its outputs in DIR/runs/<id>/; "
                    "DIR/batch.csv and DIR/batch.json hold one row per run.")
    b.add_argument("spec", metavar="SPEC.toml",
                   help="batch spec: [[sweep]] tables with args = [...] and sweep variables "
                        "(lists of values or { glob = \"pattern\" }); see examples/batch_pendulum.toml")
    b.add_argument("--out", required=True, metavar="DIR",
                   help="batch folder: runs/<id>/ per run, batch.csv and batch.json")
    b.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of a running Dask scheduler, e.g. tcp://127.0.0.1:8786 "
                        "(default: an embedded local cluster)")
    b.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes of the embedded local cluster, one thread each (default 2)")
    b.add_argument("--resume", action="store_true",
                   help="skip runs whose folder holds a done.json of a successful run with the same arguments")
    b.add_argument("--no-progress", action="store_true",
                   help="no progress line on stderr (it is shown only on a terminal anyway)")
    b.set_defaults(handler=run_batch_command)
    return b


def run_batch_command(args: argparse.Namespace) -> int:
    """Handler of ``ocp-constraints batch``: returns the exit status."""
    try:
        importlib.import_module("dask.distributed")
    except ImportError:
        print(INSTALL_HINT, file=sys.stderr)
        return 2
    from ..batch.runner import run_batch
    from ..batch.spec import load_spec

    if args.workers is not None and args.workers < 1:
        print(f"error: --workers must be at least 1, not {args.workers}", file=sys.stderr)
        return 2
    if args.workers is not None and args.scheduler:
        print("note: --workers is ignored with --scheduler (the cluster has its own workers)", file=sys.stderr)
    try:
        runs = load_spec(args.spec)
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    client = None
    if args.scheduler:
        from distributed import Client

        try:
            client = Client(args.scheduler, timeout="15s")
        except (OSError, TimeoutError, ValueError) as exc:
            print(f"error: cannot connect to the Dask scheduler at {args.scheduler}: {exc}", file=sys.stderr)
            return 2
    try:
        result = run_batch(runs, args.out, client=client, workers=args.workers or 2, resume=args.resume,
                           progress=None if not args.no_progress else False)
    except KeyboardInterrupt:
        print(f"interrupted: stopped runs are marked cancelled in {args.out}/batch.csv; "
              "rerun with --resume to finish", file=sys.stderr)
        return 130
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    finally:
        if client is not None:
            client.close()
    c = result.counts
    print(f"batch: {c['succeeded']} succeeded, {c['failed']} failed, {c['skipped']} skipped "
          f"(of {len(result.rows)} runs); table in {result.out / 'batch.csv'}")
    failed = [r for r in result.rows if r["status"] != "succeeded" and r["status"] != "skipped"]
    for row in failed[:10]:
        print(f"  {row['status']}: {row['id']}: {row['message']}")
    if len(failed) > 10:
        print(f"  ... and {len(failed) - 10} more (see batch.csv)")
    return 0 if result.ok else 1
