"""Batches of CLI runs on Dask: ``ocp-constraints batch SPEC.toml --out DIR``.

A spec (TOML) lists runs as CLI argument templates with sweep variables, expanded as a
Cartesian product (:mod:`.spec`); :func:`run_batch` runs each as
``python -m ocp_constraints ARGS`` in a Dask task, on an embedded ``LocalCluster`` or an
existing ``distributed.Client`` (:mod:`.runner`; each run a process forked from a warm server
of its worker, :mod:`.launch` and :mod:`.forkserver`), and keeps ``DIR/batch.csv`` and
``DIR/batch.json`` up to date (:mod:`.table`). The subcommand's arguments are
:mod:`ocp_constraints.cli.batch`. Dask (``dask[distributed]``, the
``batch`` extra) is imported only when a batch runs.
"""
from .runner import BatchResult, execute_run, run_batch
from ..errors import BatchSpecError
from .spec import Run, expand_sweeps, load_spec
from .table import headline, read_table

__all__ = ["run_batch", "BatchResult", "execute_run", "load_spec", "expand_sweeps", "Run",
           "BatchSpecError", "headline", "read_table"]
