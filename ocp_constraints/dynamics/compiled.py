"""Compiled CasADi functions, cached on disk by a hash of the function.

``compiled(f)`` returns ``f`` as machine code: CasADi generates C for it
(:class:`casadi.CodeGenerator`, optionally with its Jacobian ``jac_<name>`` so that
solvers such as CVODES can ask for derivatives), the system C compiler builds a shared
library, and :func:`casadi.external` loads it. The library is kept in
``$XDG_CACHE_HOME/ocp_constraints`` (default ``~/.cache/ocp_constraints``) under the
SHA-256 of the function's serialized form (which holds the whole expression graph, so a
user's scene with other parameters is another file), the CasADi version and the compiler
command; later runs load it in milliseconds. Writes go to a temporary name in the same
directory and are renamed into place, so concurrent runs never load a half-written file.

Without a C compiler (none of ``$CC``, ``cc``, ``gcc``, ``clang`` runs) or when the compiler
fails, ``f`` itself is returned (CasADi's virtual machine) and a one-line note goes to
stderr, once per process and reason.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import casadi as ca

#: Flags for the cached libraries: -O1 compiles the QR and KKT code several times faster
#: than -O2 at nearly the same speed of the result (measured on the bench scenes).
FLAGS = ("-O1", "-fPIC", "-shared")
_NOTED: set[str] = set()
#: Compiler invocations by this process (for tests and the bench: a cache hit runs none).
compiler_calls: list[list[str]] = []


def cache_dir() -> Path:
    """``$XDG_CACHE_HOME/ocp_constraints``, or ``~/.cache/ocp_constraints``."""
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "ocp_constraints"


def _compiler() -> list[str] | None:
    """The C compiler's command, looked up once per ``$CC`` and ``$PATH`` (a lookup stats ~20 files)."""
    key = (os.environ.get("CC", ""), os.environ.get("PATH", ""))
    if key not in _COMPILERS:
        _COMPILERS[key] = _find_compiler()
    found = _COMPILERS[key]
    return None if found is None else list(found)


_COMPILERS: dict[tuple[str, str], list[str] | None] = {}


def _find_compiler() -> list[str] | None:
    import shlex
    import shutil

    raw = os.environ.get("CC", "").strip()
    if raw:
        argv = shlex.split(raw)
        exe = shutil.which(argv[0]) if argv else None
        return [exe, *argv[1:]] if exe else None
    for name in ("cc", "gcc", "clang"):
        exe = shutil.which(name)
        if exe:
            return [exe]
    return None


def _note(reason: str, message: str) -> None:
    if reason not in _NOTED:
        _NOTED.add(reason)
        print(f"note: {message}", file=sys.stderr)


def library_path(f: ca.Function, with_jacobian: bool = False, cc: list[str] | None = None,
                 key: str | None = None) -> Path:
    """Where the compiled ``f`` is (or would be) cached.

    ``key``: the caller's own content hash of ``f`` (e.g. of the model file it was built
    from), used instead of ``f.serialize()``, which costs 0.1-0.5 s for a gait model's function."""
    import hashlib

    h = hashlib.sha256()
    for part in (ca.__version__, " ".join(FLAGS), " ".join(cc or []), str(with_jacobian)):
        h.update(part.encode() + b"\0")
    h.update(key.encode() if key else f.serialize().encode())
    return cache_dir() / f"{f.name()}_{h.hexdigest()[:24]}.so"


def is_cached(f: ca.Function, with_jacobian: bool = False, key: str | None = None) -> bool:
    """True if :func:`compiled` would load ``f`` from the disk cache without compiling."""
    cc = _compiler()
    return cc is not None and library_path(f, with_jacobian, cc, key).is_file()


def compiled(f: ca.Function, with_jacobian: bool = False, key: str | None = None) -> ca.Function:
    """``f`` compiled to machine code (cached on disk), or ``f`` itself without a compiler.

    ``with_jacobian`` also compiles ``f.jacobian()`` as ``jac_<name>``, which CasADi's
    external functions offer to the solvers that need first derivatives (CVODES).
    """
    import shlex
    import subprocess

    cc = _compiler()
    if cc is None:
        raw = os.environ.get("CC", "").strip()
        _note("no-compiler", f"no C compiler ({'$CC=' + raw + ' not found' if raw else 'tried cc, gcc, clang'}): "
                             "CasADi's virtual machine evaluates the model functions (slower; install gcc or clang)")
        return f
    path = library_path(f, with_jacobian, cc, key)
    if not path.is_file():
        try:
            _build(f, with_jacobian, cc, path)
        except (OSError, subprocess.SubprocessError, RuntimeError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            _note(f"failed:{shlex.join(cc)}", f"compiling '{f.name()}' with {shlex.join(cc)} failed ({first}): "
                                              "CasADi's virtual machine evaluates it instead (slower)")
            return f
    return ca.external(f.name(), str(path))


def _build(f: ca.Function, with_jacobian: bool, cc: list[str], path: Path) -> None:
    import subprocess
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ocpc_", dir=path.parent) as tmp:
        gen = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
        gen.add(f)
        if with_jacobian:
            gen.add(f.jacobian())  # named jac_<name>: what casadi.external looks for
        gen.generate(tmp + os.sep)
        so = Path(tmp) / path.name
        cmd = [*cc, *FLAGS, "-o", str(so), str(Path(tmp) / f"{f.name()}.c"), "-lm"]
        compiler_calls.append(cmd)
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr.strip() or proc.stdout.strip() or f"exit status {proc.returncode}")
        os.replace(so, path)  # atomic: a concurrent run sees the old state or the whole file


__all__ = ["compiled", "is_cached", "cache_dir", "library_path"]
