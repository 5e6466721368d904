"""Benchmark of the exported inverse-dynamics multipliers: evaluations per second.

Three ways to evaluate ``lambda(q, u, udot[, t][, inputs])`` of a scene (see
:mod:`ocp_constraints.codegen.export`), each timed ``runs`` times and reported as the median:

- ``C loop``: a small C driver calls the exported ``<p>_multipliers`` in a loop
  (``-O2``, one thread, ``clock_gettime(CLOCK_MONOTONIC)`` around the loop) on 1,024
  states near the scene's initial state, cycled;
- ``CasADi per sample``: the CasADi Function called from Python once per sample;
- ``CasADi map``: ``Function.map(batch)`` (serial) over a batch of samples.

This is a measurement, not a test: the numbers depend on the machine.
"""
from __future__ import annotations

import os
import platform
import statistics
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from ..codegen.export import C_FLAGS, ExportReport, export_c, find_compiler, run_compiler
from ..errors import ExportError

DEFAULT_SCENES = ("whirling", "rolling_disk")
DEFAULT_MARKDOWN = "results/export/bench.md"


@dataclass
class BenchRow:
    """Evaluations per second of one method on one scene (median and every run)."""

    scene: str
    method: str
    evals_per_s: float
    samples_per_run: int
    n_operations: int
    runs: list[float] = field(default_factory=list)


def _driver(report: ExportReport) -> str:
    """C source of the benchmark driver: ``bench CALLS RUNS`` prints one line per run."""
    p, P = report.prefix, report.prefix.upper()
    fn = report.function("multipliers")
    lines = ["#define _POSIX_C_SOURCE 199309L", "#include <stdio.h>", "#include <stdlib.h>", "#include <time.h>",
             f'#include "{p}_constraints.h"', "", "#define NS 1024", ""]
    for b in fn.inputs:
        if b == "t":
            lines.append("static double t[NS];")
        else:
            values = ", ".join(repr(float(v)) for v in report.sample[b])
            lines += [f"static const double {b}0[{P}_{b.upper()}_SIZE] = {{{values}}};",
                      f"static double {b}[NS][{P}_{b.upper()}_SIZE];"]
    call = ", ".join(f"{b}[i]" for b in fn.inputs)
    fill = []
    for b in fn.inputs:
        if b == "t":
            fill.append("    t[i] = 10.0 * uniform();")
        else:
            fill.append(f"    for (j = 0; j < {P}_{b.upper()}_SIZE; ++j) {b}[i][j] = {b}0[j] + 0.1 * (uniform() - 0.5);")
    lines += [
        "static unsigned long long rng = 88172645463325252ULL;",
        "static double uniform(void) {",
        "  rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17;",
        "  return (double)(rng >> 11) / 9007199254740992.0;", "}", "",
        "int main(int argc, char** argv) {",
        "  long calls = argc > 1 ? atol(argv[1]) : 1000000, k;",
        "  int runs = argc > 2 ? atoi(argv[2]) : 5, r, i, j;",
        f"  double lam[{P}_LAM_SIZE], checksum = 0.0;",
        "  for (i = 0; i < NS; ++i) {", *fill, "  }",
        "  (void)j;",
        "  for (r = 0; r < runs; ++r) {",
        "    struct timespec a, b;", "    double seconds;",
        "    clock_gettime(CLOCK_MONOTONIC, &a);",
        "    for (k = 0; k < calls; ++k) {",
        "      i = (int)(k & (NS - 1));",
        f"      if ({fn.name}({call}, lam) != 0) return 1;",
        "      checksum += lam[0];", "    }",
        "    clock_gettime(CLOCK_MONOTONIC, &b);",
        "    seconds = (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);",
        '    printf("run %d calls %ld seconds %.9f evals_per_s %.6e\\n", r, calls, seconds, (double)calls / seconds);',
        "  }",
        '  printf("checksum %.17g\\n", checksum);',
        "  return 0;", "}", ""]
    return "\n".join(lines)


def _c_loop(report: ExportReport, build: Path, cc: list[str], calls: int, runs: int) -> list[float]:
    src = report.out_dir
    driver = build / "bench.c"
    driver.write_text(_driver(report))
    exe = build / "bench"
    run_compiler([*cc, *C_FLAGS, f"-I{src}", "-o", str(exe), str(driver), str(src / f"{report.prefix}_casadi.c"),
                  str(src / f"{report.prefix}_constraints.c"), "-lm"], "the benchmark driver")
    proc = subprocess.run([str(exe), str(calls), str(runs)], capture_output=True, text=True, timeout=3600)
    if proc.returncode != 0:
        raise ExportError(f"the benchmark driver failed (status {proc.returncode}): {proc.stderr.strip()}")
    return [float(line.split()[-1]) for line in proc.stdout.splitlines() if line.startswith("run ")]


def _samples(report: ExportReport, inputs: list[str], n: int, seed: int) -> list[np.ndarray]:
    """``n`` states near the sample (rows), like the C driver's."""
    rng = np.random.default_rng(seed)
    out = []
    for b in inputs:
        if b == "t":
            out.append(rng.uniform(0.0, 10.0, (n, 1)))
        else:
            s = np.asarray(report.sample[b], float)
            out.append(s + 0.1 * (rng.uniform(size=(n, s.size)) - 0.5))
    return out


def _python_per_sample(f: ca.Function, args: list[np.ndarray], runs: int) -> list[float]:
    n = args[0].shape[0]
    rates = []
    for _ in range(runs):
        started = time.perf_counter()
        for k in range(n):
            f(*[a[k] for a in args])
        rates.append(n / (time.perf_counter() - started))
    return rates


def _python_map(f: ca.Function, args: list[np.ndarray], runs: int) -> list[float]:
    n = args[0].shape[0]
    fm = f.map(n)
    cols = [np.ascontiguousarray(a.T) for a in args]
    rates = []
    for _ in range(runs):
        started = time.perf_counter()
        np.asarray(fm(*cols))
        rates.append(n / (time.perf_counter() - started))
    return rates


def benchmark_export(scenes=DEFAULT_SCENES, runs: int = 5, c_calls: int = 1_000_000, python_calls: int = 10_000,
                     batch: int = 10_000, markdown: str | Path | None = None, cc: str | None = None,
                     seed: int = 0) -> list[BenchRow]:
    """Evaluations per second of the exported multipliers, three ways (see module docs).

    Parameters
    ----------
    scenes
        Built-in scene names or scene files, exported with default parameters.
    runs
        Timed repetitions per method; the median is reported.
    c_calls, python_calls, batch
        Calls per run in the C loop, calls per run from Python, samples per ``map`` call.
    markdown
        If given, write the table there (Markdown), through a temporary file and a rename.
    cc
        C compiler command (default ``$CC``, else ``cc``).

    Returns
    -------
    list of BenchRow
        One row per scene and method.
    """
    if runs < 1 or c_calls < 1 or python_calls < 1 or batch < 1:
        raise ExportError("benchmark: runs and sample counts must be positive")
    compiler = find_compiler(cc)
    rows = []
    for scene in scenes:
        with tempfile.TemporaryDirectory(prefix="ocp-export-bench-") as tmp:
            report = export_c(scene, Path(tmp) / "export")
            fn = report.function("multipliers")
            c_rates = _c_loop(report, Path(tmp), compiler, c_calls, runs)
        ops = fn.n_operations
        rows.append(BenchRow(report.scene, "C loop (-O2), exported function", statistics.median(c_rates), c_calls, ops, c_rates))
        per = _python_per_sample(fn.function, _samples(report, fn.inputs, python_calls, seed), runs)
        rows.append(BenchRow(report.scene, "CasADi Function from Python, per sample", statistics.median(per),
                             python_calls, ops, per))
        mapped = _python_map(fn.function, _samples(report, fn.inputs, batch, seed), runs)
        rows.append(BenchRow(report.scene, f"CasADi map over a batch of {batch}", statistics.median(mapped), batch, ops, mapped))
    if markdown is not None:
        write_markdown(rows, Path(markdown), compiler, runs)
    return rows


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _compiler_version(cc: list[str]) -> str:
    try:
        out = subprocess.run([*cc, "--version"], capture_output=True, text=True, timeout=30).stdout
        return out.splitlines()[0].strip() if out else cc[0]
    except (OSError, subprocess.TimeoutExpired):
        return cc[0]


def markdown_table(rows: list[BenchRow], cc: list[str], runs: int) -> str:
    """The rows as a Markdown table, with the machine and the command to reproduce them."""
    scenes = " ".join(dict.fromkeys(r.scene for r in rows))
    lines = [
        "# Exported inverse-dynamics multipliers: evaluations per second", "",
        f"Command: `ocp-constraints bench-export {scenes} --runs {runs} --markdown {DEFAULT_MARKDOWN}`",
        f"(or `python -c \"from ocp_constraints.bench.export_speed import benchmark_export; "
        f"benchmark_export({tuple(scenes.split())!r}, runs={runs}, markdown='{DEFAULT_MARKDOWN}')\"`).", "",
        f"Machine: {_cpu_name()}, {os.cpu_count()} logical cores (one used); compiler: {_compiler_version(cc)}, "
        f"flags `{' '.join(C_FLAGS)}`; CasADi {ca.__version__}; Python {platform.python_version()}.", "",
        f"| scene | method | evaluations/s (median of {runs}) | min | max | samples per run | operations |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(f"| {r.scene} | {r.method} | {r.evals_per_s:.3g} | {min(r.runs):.3g} | {max(r.runs):.3g} "
                     f"| {r.samples_per_run} | {r.n_operations} |")
    return "\n".join(lines) + "\n"


def write_markdown(rows: list[BenchRow], path: Path, cc: list[str], runs: int) -> None:
    from ..output.files import write_atomic

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, markdown_table(rows, cc, runs).encode())
    except OSError as exc:
        raise ExportError(f"cannot write the benchmark table to '{path}': {exc.strerror or exc}") from exc
