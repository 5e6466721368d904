"""The background compile of ``compiled(..., when_missing="background")`` (issue 14, the gait command's
``auto``): a cache miss returns the virtual machine's function at once and a detached process builds the
library, which the next call loads; one compile per library at a time; a damaged library in the cache is
never loaded; a failed compile is remembered, not retried; no compiler means the virtual machine and a
note. The compiled numbers are checked against CasADi's virtual machine (an equivalence check of the
compilation) and against NumPy's evaluation of the same closed form."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.dynamics import compiled as comp

pytestmark = pytest.mark.skipif(comp._compiler() is None, reason="no C compiler on this machine")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A private cache folder and this process's memory of notes and jobs emptied."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(comp, "_NOTED", set())
    monkeypatch.setattr(comp, "background_jobs", [])
    monkeypatch.setattr(comp, "_VALID", {})
    monkeypatch.setattr(comp, "NICE", 0)        # the test waits for the build: not behind the rest of the suite
    return tmp_path / "ocp_constraints"


def _function(name: str = "bg_probe") -> ca.Function:
    x = ca.SX.sym("x", 3)
    return ca.Function(name, [x], [ca.sin(x) * x[0] + ca.exp(x[2]), ca.dot(x, x)])


def _closed_form(x):
    x = np.asarray(x, float)
    return np.sin(x) * x[0] + np.exp(x[2]), float(x @ x)


def _wait(timeout: float = 120.0) -> None:
    for job in comp.background_jobs:
        assert job.wait(timeout) == 0


def test_cache_miss_returns_the_virtual_machine_and_the_next_call_loads_the_background_build(cache, capsys):
    f = _function()
    assert comp.compiled(f, when_missing="background", what="the probe") is f
    assert comp.compiled(f, when_missing="background", what="the probe") is f     # still building: no second job
    assert len(comp.background_jobs) == 1
    err = capsys.readouterr().err
    assert err == "note: compiling the probe in the background for later runs\n"
    _wait()
    calls = len(comp.compiler_calls)
    fast = comp.compiled(f, when_missing="background")
    assert fast.class_name() == "External" and len(comp.compiler_calls) == calls    # loaded, not compiled here
    x = [0.3, -1.2, 0.7]
    a, b = _closed_form(x)
    np.testing.assert_allclose(np.asarray(fast(x)[0]).ravel(), a, rtol=1e-14)
    assert float(fast(x)[1]) == pytest.approx(b, rel=1e-14)
    assert sorted(p.name for p in cache.iterdir()) == sorted([comp.library_path(f, cc=comp._compiler()).name,
                                                              comp.library_path(f, cc=comp._compiler()).name + ".sha256"])


def test_a_damaged_library_in_the_cache_is_never_loaded(cache):
    f = _function("bg_damaged")
    comp.compiled(f)                                          # a whole library, built now
    path = comp.library_path(f, cc=comp._compiler())
    assert comp.is_cached(f)
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) // 2])                # truncated, as by a full disk or a half copy
    comp._VALID.clear()
    assert not comp.is_cached(f)
    assert comp.compiled(f, when_missing="background") is f   # the virtual machine, and a rebuild started
    _wait()
    assert path.read_bytes() == whole or comp.is_cached(f)
    assert comp.compiled(f).class_name() == "External"


def test_a_library_without_its_checksum_is_not_loaded(cache):
    f = _function("bg_unchecked")
    path = comp.library_path(f, cc=comp._compiler())
    path.parent.mkdir(parents=True)
    path.write_bytes(b"\x7fELF not really a library")         # e.g. left by another tool or an old version
    assert not comp.is_cached(f)
    assert comp.compiled(f, when_missing="background") is f


def test_a_failed_compile_is_remembered_and_not_retried(cache, monkeypatch, capsys):
    monkeypatch.setenv("CC", "false")                         # a compiler that always fails
    f = _function("bg_fails")
    assert comp.compiled(f, when_missing="background") is f
    _wait()
    failed = comp.library_path(f, cc=comp._compiler()).with_suffix(".so.failed")
    assert failed.is_file() and not list(cache.glob("*.lock")) and not list(cache.glob("ocpc_*"))
    capsys.readouterr()
    assert comp.compiled(f, when_missing="background") is f
    assert len(comp.background_jobs) == 1                     # no second attempt
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "failed" in err and str(failed) in err


def test_a_stale_lock_is_taken_over_and_a_live_one_is_respected(cache):
    import os
    import socket

    f = _function("bg_locked")
    lock = comp.library_path(f, cc=comp._compiler()).with_suffix(".so.lock")
    lock.parent.mkdir(parents=True)
    lock.write_text(f"{socket.gethostname()} {os.getpid()}\n")       # a live holder (this process)
    assert comp.compiled(f, when_missing="background") is f and comp.background_jobs == []
    old = 1e9
    os.utime(lock, (old, old))                                        # older than LOCK_TTL_S: stale
    assert comp.compiled(f, when_missing="background") is f and len(comp.background_jobs) == 1
    _wait()
    assert comp.is_cached(f) and not lock.exists()


def test_without_a_compiler_the_background_policy_keeps_the_virtual_machine_with_a_note(cache, monkeypatch, capsys):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    f = _function("bg_nocc")
    assert comp.compiled(f, when_missing="background") is f
    assert comp.background_jobs == []
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no C compiler" in err
