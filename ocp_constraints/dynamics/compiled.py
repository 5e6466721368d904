"""Compiled CasADi functions, cached on disk by a hash of the function; compiled now or in the background.

``compiled(f)`` returns ``f`` as machine code: CasADi generates C for it
(:class:`casadi.CodeGenerator`, optionally with its Jacobian ``jac_<name>`` so that
solvers such as CVODES can ask for derivatives), the system C compiler builds a shared
library, and :func:`casadi.external` loads it. The library is kept in
``$XDG_CACHE_HOME/ocp_constraints`` (default ``~/.cache/ocp_constraints``) under the
SHA-256 of the function's serialized form (which holds the whole expression graph, so a
user's scene with other parameters is another file), the CasADi version and the compiler
command; later runs load it in milliseconds.

A library is only ever loaded whole and checked: it is built in a temporary folder, evaluated
there against ``f`` on random inputs (the same numbers as CasADi's virtual machine, else it is
rejected), and renamed into place next to a ``.sha256`` file of its bytes; a library whose bytes
do not match (truncated, damaged, copied half) is never loaded.

``when_missing="background"`` (the ``auto`` policy of the gait command): on a cache miss this run
keeps ``f`` (the virtual machine) and a detached process (own session, lowest priority; it
survives this process's exit) compiles the library for later runs. A ``.lock`` file next to the
library keeps two runs from compiling the same function at once (a lock older than
:data:`LOCK_TTL_S`, or whose process on this host is gone, is stale and taken over); a failed
compile leaves a ``.failed`` file with the compiler's message and is not tried again in the
background until that file is deleted.

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
#: ``-O0`` instead, for very large functions, whose ``-O1`` compile grows faster than
#: their size (a UR5's Lagrangian Hessian at a collocation point, 70,855 operations: 44 s at -O1, 2.9 s at -O0,
#: evaluating 18x and 5.7x faster than the virtual machine; ``python scripts/compiled_elements_calibration.py``).
FLAGS_QUICK = ("-O0", "-fPIC", "-shared")
#: A compile lock older than this is stale (the compiler's own timeout is 600 s).
LOCK_TTL_S = 900.0
#: Niceness of a background compile: the run that started it (and everyone else) goes first.
NICE = 19
_NOTED: set[str] = set()
#: Compiler invocations by this process (for tests and the bench: a cache hit runs none).
compiler_calls: list[list[str]] = []
#: Background compiles started by this process (``subprocess.Popen``; tests wait on them).
background_jobs: list = []
_VALID: dict[str, tuple[int, int]] = {}      # libraries whose bytes were checked: path -> (mtime_ns, size)


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
                 key: str | None = None, flags: tuple[str, ...] = FLAGS) -> Path:
    """Where the compiled ``f`` is (or would be) cached.

    ``key``: the caller's own content hash of ``f`` (e.g. of the model file it was built
    from), used instead of ``f.serialize()``, which costs 0.1-0.5 s for a gait model's function."""
    import hashlib

    h = hashlib.sha256()
    for part in (ca.__version__, " ".join(flags), " ".join(cc or []), str(with_jacobian)):
        h.update(part.encode() + b"\0")
    h.update(key.encode() if key else f.serialize().encode())
    return cache_dir() / f"{f.name()}_{h.hexdigest()[:24]}.so"


def _sidecar(path: Path, suffix: str) -> Path:
    return path.with_name(path.name + suffix)


def _digest(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def _valid(path: Path) -> bool:
    """True if ``path`` is a whole library as its builder wrote it (its bytes match its ``.sha256``)."""
    try:
        st = path.stat()
        if _VALID.get(str(path)) == (st.st_mtime_ns, st.st_size):
            return True
        if _sidecar(path, ".sha256").read_text().strip() != _digest(path):
            return False
    except OSError:          # absent library or absent checksum: not a library of ours
        return False
    _VALID[str(path)] = (st.st_mtime_ns, st.st_size)
    return True


def is_cached(f: ca.Function, with_jacobian: bool = False, key: str | None = None, flags: tuple[str, ...] = FLAGS) -> bool:
    """True if :func:`compiled` would load ``f`` from the disk cache without compiling."""
    cc = _compiler()
    return cc is not None and _valid(library_path(f, with_jacobian, cc, key, flags))


def compiled(f: ca.Function, with_jacobian: bool = False, key: str | None = None, when_missing: str = "now",
             what: str | None = None, flags: tuple[str, ...] = FLAGS) -> ca.Function:
    """``f`` compiled to machine code (cached on disk), or ``f`` itself without a compiler.

    ``with_jacobian`` also compiles ``f.jacobian()`` as ``jac_<name>``, which CasADi's
    external functions offer to the solvers that need first derivatives (CVODES).
    ``when_missing``: on a cache miss, ``"now"`` compiles before returning (seconds), ``"background"``
    returns ``f`` and compiles it in a detached process for later runs (see the module docstring).
    ``what``: how the notes name ``f`` (default its name). ``flags``: :data:`FLAGS` or :data:`FLAGS_QUICK`
    (compiled now only; a background compile uses :data:`FLAGS`).
    """
    import shlex
    import subprocess

    if when_missing not in ("now", "background"):
        raise ValueError(f"compiled(): when_missing must be 'now' or 'background', got {when_missing!r}")
    cc = _compiler()
    if cc is None:
        raw = os.environ.get("CC", "").strip()
        _note("no-compiler", f"no C compiler ({'$CC=' + raw + ' not found' if raw else 'tried cc, gcc, clang'}): "
                             "CasADi's virtual machine evaluates the model functions (slower; install gcc or clang)")
        return f
    if when_missing == "background":
        flags = FLAGS
    path = library_path(f, with_jacobian, cc, key, flags)
    if not _valid(path):
        if when_missing == "background":
            _start_background(f, with_jacobian, cc, path, what or f"'{f.name()}'")
            return f
        try:
            _build(f, with_jacobian, cc, path, flags)
        except (OSError, subprocess.SubprocessError, RuntimeError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            _note(f"failed:{shlex.join(cc)}", f"compiling '{f.name()}' with {shlex.join(cc)} failed ({first}): "
                                              "CasADi's virtual machine evaluates it instead (slower)")
            return f
    try:
        return ca.external(f.name(), str(path))
    except RuntimeError as exc:       # checksum right but the loader refuses it (another libc, say)
        _note(f"load:{path}", f"could not load {path} ({str(exc).strip().splitlines()[0]}): CasADi's virtual "
                              "machine evaluates it instead; delete the file to build it again")
        return f


def _build(f: ca.Function, with_jacobian: bool, cc: list[str], path: Path, flags: tuple[str, ...] = FLAGS) -> None:
    """Generate C, compile, check the library against ``f``, and rename it with its checksum into place."""
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
        cmd = [*cc, *flags, "-o", str(so), str(Path(tmp) / f"{f.name()}.c"), "-lm"]
        compiler_calls.append(cmd)
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr.strip() or proc.stdout.strip() or f"exit status {proc.returncode}")
        _check_equal(f, ca.external(f.name(), str(so)))
        digest = _sidecar(so, ".sha256")
        digest.write_text(_digest(so) + "\n")
        # checksum first, then the library: whoever sees the library sees its checksum (each rename atomic)
        os.replace(digest, _sidecar(path, ".sha256"))
        os.replace(so, path)
    _sidecar(path, ".failed").unlink(missing_ok=True)      # an earlier failure is history now


def _check_equal(f: ca.Function, lib: ca.Function) -> None:
    """Raise unless the library gives ``f``'s numbers at three random inputs (a wrong build is never cached)."""
    import numpy as np

    rng = np.random.default_rng(0)
    for _ in range(3):
        args = [rng.uniform(0.1, 1.0, f.sparsity_in(i).nnz()) for i in range(f.n_in())]
        args = [ca.DM(f.sparsity_in(i), a) for i, a in enumerate(args)]
        for i, (a, b) in enumerate(zip(f.call(args), lib.call(args))):
            a, b = np.asarray(ca.densify(a)), np.asarray(ca.densify(b))
            if not np.allclose(a, b, rtol=1e-8, atol=1e-8 * (1.0 + np.nanmax(np.abs(a), initial=0.0)), equal_nan=True):
                raise RuntimeError(f"the compiled '{f.name()}' differs from CasADi's evaluation in output "
                                   f"'{f.name_out(i)}' (max difference {np.nanmax(np.abs(a - b)):.3g})")


def _lock_is_stale(lock: Path) -> bool:
    """A lock older than :data:`LOCK_TTL_S`, or held by a process of this host that is gone."""
    import socket
    import time

    try:
        if time.time() - lock.stat().st_mtime > LOCK_TTL_S:
            return True
        host, pid = lock.read_text().split()
    except (OSError, ValueError):        # gone meanwhile, or written but not yet filled: not stale
        return False
    if host != socket.gethostname():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except (PermissionError, ValueError):
        return False
    return False


def _take_lock(lock: Path) -> bool:
    """Create ``lock`` exclusively (True), taking over a stale one; False while another run holds it."""
    import socket

    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            if not _lock_is_stale(lock):
                return False
            try:
                os.unlink(lock)
            except OSError:
                pass
            continue
        with os.fdopen(fd, "w") as fh:
            fh.write(f"{socket.gethostname()} {os.getpid()}\n")
        return True
    return False


def _start_background(f: ca.Function, with_jacobian: bool, cc: list[str], path: Path, what: str) -> None:
    """Start a detached process that builds ``path`` from ``f`` (see the module docstring); this run keeps ``f``."""
    import json
    import shutil
    import socket
    import subprocess
    import tempfile

    failed = _sidecar(path, ".failed")
    if failed.is_file():
        _note(f"failed:{path}", f"an earlier compile of {what} failed (see {failed}): CasADi's virtual machine "
                                "evaluates it; delete that file to compile it again")
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        _note(f"cache:{path.parent}", f"cannot write the cache folder {path.parent} ({exc}): {what} runs on "
                                      "CasADi's virtual machine")
        return
    lock = _sidecar(path, ".lock")
    if not _take_lock(lock):
        if any(getattr(job, "library", None) == path for job in background_jobs):
            return                   # this process started it already
        _note(f"busy:{path}", f"{what} is being compiled by another run; this run uses CasADi's virtual machine")
        return
    tmp = None
    try:
        tmp = tempfile.mkdtemp(prefix="ocpc_bg_", dir=path.parent)
        source = Path(tmp) / "function.casadi"
        f.save(str(source))
        root = str(Path(__file__).resolve().parents[2])      # this package's folder, whatever the child's cwd
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH", "")) if p)}
        proc = subprocess.Popen([sys.executable, "-c", "from ocp_constraints.dynamics.compiled import "
                                 "_background_main; _background_main()", str(source), str(path),
                                 "1" if with_jacobian else "0", json.dumps(cc), str(lock), str(NICE)],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                cwd=tmp, env=env, start_new_session=True)     # own session: outlives us, no SIGINT
    except (OSError, RuntimeError, subprocess.SubprocessError) as exc:
        lock.unlink(missing_ok=True)
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
        _note(f"spawn:{path}", f"could not start compiling {what} ({exc}): CasADi's virtual machine evaluates it")
        return
    lock.write_text(f"{socket.gethostname()} {proc.pid}\n")     # the compiler's process holds the lock now
    proc.library = path
    for job in background_jobs:
        job.poll()             # reap finished compiles (no zombie per compiled model in a long-lived process)
    background_jobs.append(proc)
    _note(f"background:{path}", f"compiling {what} in the background for later runs")


def _background_main() -> None:
    """The detached compile: ``argv = [function file, library path, with_jacobian 0/1, cc (JSON), lock, niceness]``."""
    import json
    import shutil

    source, path, jac, cc, lock, nice = sys.argv[1:7]
    path = Path(path)
    try:
        os.nice(int(nice))
    except OSError:
        pass
    try:
        _build(ca.Function.load(source), jac == "1", json.loads(cc), path)
    except BaseException as exc:       # remembered: the background never tries this library again by itself
        failed = _sidecar(path, ".failed")
        tmp = _sidecar(path, f".failed.{os.getpid()}")
        tmp.write_text(f"{type(exc).__name__}: {exc}\n")
        os.replace(tmp, failed)
    finally:
        shutil.rmtree(Path(source).parent, ignore_errors=True)
        Path(lock).unlink(missing_ok=True)


__all__ = ["compiled", "is_cached", "cache_dir", "library_path", "background_jobs", "LOCK_TTL_S"]
