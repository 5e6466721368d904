"""Compiling an export and checking its round trip against the CasADi evaluation.

The errors of the C export, the compiler helpers (:func:`find_compiler`,
:func:`run_compiler`, :func:`build_export`) and :func:`verify_export`, which builds the
library and example of an export, loads them back and compares them with CasADi.
"""
from __future__ import annotations

import ctypes
import os
import shlex
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

from ..errors import CompilerError, CompilerNotFoundError, RoundTripError
from ..mechanics.equations import SystemEquations
from .layout import C_FLAGS, TOLERANCE, ExportedFunction, ExportReport, RoundTripReport
from ..mechanics.rotations import EulerSequence




# -- compiling and the round trip ---------------------------------------------------------
def find_compiler(cc: str | None = None) -> list[str]:
    """The C compiler command: ``cc`` if given, else ``$CC``, else ``cc``, ``gcc`` or ``clang``."""
    raw = cc if cc is not None else os.environ.get("CC", "").strip() or None
    if raw is not None:
        argv = shlex.split(raw)
        exe = shutil.which(argv[0]) if argv else None
        if exe is None:
            source = "given" if cc is not None else "from $CC"
            raise CompilerNotFoundError(f"C compiler '{raw}' ({source}) not found: no such program. "
                                        "Install gcc or clang, or point $CC to one")
        return [exe, *argv[1:]]
    for name in ("cc", "gcc", "clang"):
        exe = shutil.which(name)
        if exe:
            return [exe]
    raise CompilerNotFoundError("no C compiler found (tried cc, gcc, clang): install one or set $CC")


def run_compiler(cmd: list[str], what: str) -> str:
    """Run a compiler command; return its (warning) output, raise :class:`CompilerError`."""
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except FileNotFoundError as exc:
        raise CompilerNotFoundError(f"C compiler '{cmd[0]}' not found: {exc.strerror}") from exc
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise CompilerError(f"the C compiler could not build {what}: $ {shlex.join(cmd)}: {exc}") from exc
    if proc.returncode != 0:
        message = (proc.stderr.strip() or proc.stdout.strip() or "(no output)")
        raise CompilerError(f"the C compiler failed building {what} (exit status {proc.returncode}):\n"
                            f"$ {shlex.join(cmd)}\n{message}")
    return (proc.stderr + proc.stdout).strip()


def build_export(src: Path, prefix: str, build: Path, cc: list[str]) -> tuple[Path, Path, str]:
    """Compile the library and the example of the export in ``src`` into ``build``.

    Same flags as the generated Makefile. Returns the library, the program and any
    compiler output (warnings; with ``-Werror`` there are none on success).
    """
    lib = build / f"lib{prefix}_constraints.so"
    exe = build / f"{prefix}_example"
    out = run_compiler([*cc, *C_FLAGS, "-fPIC", "-shared", "-o", str(lib), str(src / f"{prefix}_casadi.c"),
                        str(src / f"{prefix}_constraints.c"), "-lm"], f"{lib.name}")
    out += run_compiler([*cc, *C_FLAGS, "-o", str(exe), str(src / f"{prefix}_example.c"), f"-L{build}",
                         f"-l{prefix}_constraints", f"-Wl,-rpath,{build}", "-lm"], f"{exe.name}")
    return lib, exe, out


def relative_error(computed, reference) -> float:
    """Max over rows of ``max|computed - reference| / max|reference|`` (0 when both are zero)."""
    c, r = np.atleast_2d(np.asarray(computed, float)), np.atleast_2d(np.asarray(reference, float))
    if c.shape != r.shape or not np.array_equal(np.isfinite(c), np.isfinite(r)):
        return float("inf")
    c, r = np.where(np.isfinite(r), c, 0.0), np.where(np.isfinite(r), r, 0.0)
    num, den = np.abs(c - r).max(axis=1, initial=0.0), np.abs(r).max(axis=1, initial=0.0)
    ratio = np.divide(num, den, out=np.where(num > 0, np.inf, 0.0), where=den > 0)
    return float(ratio.max(initial=0.0))


def random_states(report_or_eqs, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """``n`` random samples per input block (rows are samples), away from Euler singularities.

    Positions and speeds standard normal, Euler angles uniform with the middle angle at
    least 0.3 rad from its singularity, unit quaternions uniform, ``t`` in [0, 10] s.
    """
    eqs = report_or_eqs if isinstance(report_or_eqs, SystemEquations) else report_or_eqs.eqs
    rng = np.random.default_rng(seed)
    q = []
    for b in eqs.bodies:
        q.append(rng.standard_normal((n, 3)))
        if isinstance(b.rotation, EulerSequence):
            lo, hi = (0.3, np.pi - 0.3) if b.rotation.is_proper else (-np.pi / 2 + 0.3, np.pi / 2 - 0.3)
            mid = rng.uniform(lo, hi, n)
            q.append(np.column_stack([rng.uniform(-np.pi, np.pi, n), mid, rng.uniform(-np.pi, np.pi, n)]))
        else:
            r = rng.standard_normal((n, 4))
            q.append(r / np.linalg.norm(r, axis=1, keepdims=True))
    out = {"q": np.hstack(q), "u": rng.standard_normal((n, eqs.nu)), "udot": rng.standard_normal((n, eqs.nu)),
           "t": rng.uniform(0.0, 10.0, (n, 1)), "lam": rng.standard_normal((n, eqs.nc))}
    if eqs.inputs.numel():
        out["inputs"] = rng.standard_normal((n, eqs.inputs.numel()))
    return out


def _evaluate(f: ca.Function, args: list[np.ndarray]) -> list[np.ndarray]:
    """``f`` mapped over rows of ``args``; outputs with rows as samples."""
    n = args[0].shape[0]
    res = f.map(n)(*[a.T for a in args])
    res = res if isinstance(res, (list, tuple)) else [res]
    return [np.asarray(r).reshape(-1, n).T for r in res]


def _call_c_api(lib: ctypes.CDLL, report: ExportReport, fn: ExportedFunction, args: list[np.ndarray]) -> list[np.ndarray]:
    n = args[0].shape[0]
    cfun = getattr(lib, fn.name)
    cfun.restype = ctypes.c_int
    dptr = ctypes.POINTER(ctypes.c_double)
    outs = [np.zeros((n, report.blocks[b].size)) for b in fn.outputs]
    for k in range(n):
        cargs = [ctypes.c_double(a[k, 0]) if b == "t" else a[k].ctypes.data_as(dptr) for b, a in zip(fn.inputs, args)]
        cargs += [o[k].ctypes.data_as(dptr) for o in outs]
        if cfun(*cargs) != 0:
            raise RoundTripError(f"{fn.name} returned an error at random state {k}")
    return outs


def _parse_example(text: str) -> dict[tuple[str, str], dict[int, float]]:
    values: dict[tuple[str, str], dict[int, float]] = {}
    for line in text.splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        fn, block, index, _, value = line.split()
        values.setdefault((fn, block), {})[int(index)] = float(value)
    return values


def check_example_output(report: ExportReport, text: str) -> dict[str, float]:
    """Relative error of each printed output of the example against CasADi at the sample."""
    printed = _parse_example(text)
    lam_key = (report.function("multipliers").name, "lam")
    if lam_key not in printed:
        raise RoundTripError(f"the example program printed no multipliers:\n{text[:2000]}")
    sample = dict(report.sample, lam=np.array([printed[lam_key][i] for i in sorted(printed[lam_key])]))
    errors = {}
    for fn in report.functions:
        ref = fn.function(*[sample[b] for b in fn.inputs])
        ref = ref if isinstance(ref, (list, tuple)) else [ref]
        for b, r in zip(fn.outputs, ref):
            got = printed.get((fn.name, b), {})
            c = np.array([got.get(i, np.nan) for i in range(report.blocks[b].size)])
            errors[f"{fn.name}.{b}"] = relative_error(c, np.asarray(r).ravel())
    return errors


def verify_export(report: ExportReport, n_states: int = 1000, seed: int = 0, cc: str | None = None) -> RoundTripReport:
    """Compile the export, load it back and compare with CasADi on ``n_states`` random states.

    Builds in a temporary folder (the export folder is not touched) with the flags of the
    Makefile; compares the CasADi interface (``casadi.external``) and the plain C API
    (``ctypes``) of every function, and runs the example program and checks its printout.

    Raises
    ------
    CompilerNotFoundError, CompilerError
        No compiler, or the compiler failed (its own message is included).
    RoundTripError
        A relative error above ``1e-12``.
    """
    compiler = find_compiler(cc)
    states = random_states(report, n_states, seed)
    with tempfile.TemporaryDirectory(prefix=f"ocp-export-{report.prefix}-") as build:
        started = time.perf_counter()
        lib_path, exe, output = build_export(report.out_dir, report.prefix, Path(build), compiler)
        build_seconds = time.perf_counter() - started
        lib = ctypes.CDLL(str(lib_path))
        external, c_api = {}, {}
        for fn in report.functions:
            args = [states[b] for b in fn.inputs]
            ref = _evaluate(fn.function, args)
            ext = _evaluate(ca.external(fn.casadi_name, str(lib_path)), args)
            external[fn.name] = max(relative_error(a, b) for a, b in zip(ext, ref))
            c_api[fn.name] = max(relative_error(a, b) for a, b in zip(_call_c_api(lib, report, fn, args), ref))
        try:
            proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise RoundTripError(f"the example program {exe.name} could not run: {exc}") from exc
        if proc.returncode != 0:
            raise RoundTripError(f"the example program {exe.name} failed (status {proc.returncode}): {proc.stderr.strip()}")
        example = check_example_output(report, proc.stdout)
    rt = RoundTripReport(n_states, seed, shlex.join(compiler), external, c_api, example, output, build_seconds)
    if not rt.passed:
        worst = sorted({**{f"casadi_external {k}": v for k, v in external.items()},
                        **{f"C API {k}": v for k, v in c_api.items()},
                        **{f"example {k}": v for k, v in example.items()}}.items(), key=lambda kv: -kv[1])[:3]
        raise RoundTripError(f"export of '{report.scene}' disagrees with CasADi beyond {TOLERANCE:g} (relative): "
                             + "; ".join(f"{k}: {v:.3g}" for k, v in worst))
    return rt

