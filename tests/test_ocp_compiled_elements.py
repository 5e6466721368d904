"""Element functions as machine code (ocp/compiled_elements.py): the same NLP, the same optimum, a clear
refusal of a bad policy, the virtual machine when there is no compiler, and small problems left alone."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.dynamics import compiled as compiled_module
from ocp_constraints.ocp import compiled_elements
from ocp_constraints.scenes.registry import build_task


def _swing_up(policy: str):
    problem = build_task("pendulum", "swing_up")[1]
    problem.compiled = policy
    return problem


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory):
    """One cache folder for this file's tests: the swing-up's functions are compiled once (~0.3 s each)."""
    return tmp_path_factory.mktemp("ocp_compiled_cache")


@pytest.fixture
def own_cache(module_cache, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(module_cache))
    monkeypatch.setattr(compiled_module, "_VALID", {})
    return module_cache


def test_compiled_derivatives_give_the_virtual_machines_numbers_and_optimum(own_cache):
    scheme = oc.Radau(8, degree=4)
    machine, vm = _swing_up("always"), _swing_up("never")
    tm, tv = machine.transcription(scheme), vm.transcription(scheme)
    assert tm.machine_code.compiled and not tv.machine_code.compiled
    rng = np.random.default_rng(0)
    n, m = tv.block.n, tv.block.m
    for _ in range(3):
        x, lam = rng.uniform(-1, 1, n), rng.uniform(-1, 1, m)
        fg = [ca.Function("fg", [t.block.w], [t.block.f, t.block.g]) for t in (tm, tv)]
        for u, w in zip(fg[0](x), fg[1](x)):
            assert np.allclose(np.asarray(u), np.asarray(w), rtol=1e-12, atol=1e-12)
        for name, args in (("grad_f", (x, [])), ("jac_g", (x, [])), ("hess_lag", (x, [], 0.7, lam))):
            a, b = (getattr(t.block, name)(*args) for t in (tm, tv))
            a, b = ([np.asarray(v.full()) for v in (r if isinstance(r, (list, tuple)) else [r])] for r in (a, b))
            for u, w in zip(a, b):
                assert np.allclose(u, w, rtol=1e-12, atol=1e-12 * (1 + np.abs(w).max())), name
    sm, sv = machine.solve(scheme), vm.solve(scheme)
    assert abs(sm.objective - sv.objective) <= 1e-9 * abs(sv.objective)
    t = np.linspace(0, sv.t[-1], 41)
    assert np.allclose(sm.interpolate("hinge.v1.lambda", t), sv.interpolate("hinge.v1.lambda", t), rtol=1e-7, atol=1e-7)


def test_auto_leaves_a_small_problem_on_the_virtual_machine(own_cache):
    calls = len(compiled_module.compiler_calls)
    problem = _swing_up("auto")
    tr = problem.transcription(oc.Radau(10, degree=3))
    assert tr.machine_code.compiled == [] and len(compiled_module.compiler_calls) == calls


def test_auto_loads_what_an_earlier_run_compiled(own_cache, monkeypatch):
    scheme = oc.Radau(6, degree=3)
    first = _swing_up("always").transcription(scheme)
    assert first.machine_code.compiled
    calls = len(compiled_module.compiler_calls)
    monkeypatch.setattr(compiled_elements, "MIN_VM_SECONDS", 0.0)       # look every function up, small or not
    again = _swing_up("auto").transcription(scheme)
    assert sorted(again.machine_code.compiled) == sorted(first.machine_code.compiled)
    assert len(compiled_module.compiler_calls) == calls                   # loaded, not compiled


def test_a_bad_compiled_policy_is_refused_naming_it():
    with pytest.raises(oc.ModelError, match="compiled must be one of auto, always, never, got 'fast'"):
        _swing_up("fast").solve(oc.Radau(4, degree=3))


def test_without_a_compiler_the_virtual_machine_solves_and_a_note_says_so(own_cache, monkeypatch, capsys):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    monkeypatch.setattr(compiled_module, "_NOTED", set())
    problem = _swing_up("always")
    sol = problem.solve(oc.Radau(6, degree=3))
    assert sol.stats["success"] and problem.transcription(oc.Radau(6, degree=3)).machine_code.compiled == []
    assert "no C compiler" in capsys.readouterr().err


def test_auto_compiles_once_the_savings_missed_reach_the_compile_time(tmp_path, monkeypatch):
    """Ski rental: a function whose one solve saves 0.6 of its compile time stays on the virtual machine
    for its first mesh and is compiled for its second (the savings missed and due: 1.2 of it)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))          # nothing compiled before: an empty cache
    monkeypatch.setattr(compiled_module, "_VALID", {})
    monkeypatch.setattr(compiled_elements, "MIN_VM_SECONDS", 0.0)
    problem = _swing_up("never")
    problem.transcription(oc.Radau(4, degree=3))
    f = next(iter(v for v in problem._element_derivatives.values() if isinstance(v, dict) and v["hess"]))["hess"][0]
    e, size = compiled_elements.EVALUATIONS["hess"], compiled_elements.Size.of(f)
    price = f.n_instructions() * compiled_elements.COMPILE_S[size.flags]     # the docstring's n COMPILE_S
    saving_one = f.n_instructions() * e * (compiled_elements.VM_NS - compiled_elements.COMPILED_NS[size.flags]) * 1e-9
    K = int(round(0.6 * price / saving_one))
    machine = compiled_elements.MachineCode("auto")
    assert machine(f, K, "hess") is f and machine.compiled == []
    copy = machine(f, K, "hess")
    assert copy is not f and machine.compiled == [f.name()]
    assert machine(f, 1, "hess") is copy                    # kept for the later meshes, whatever their size


def test_what_a_solve_keeps_on_the_problem_stays_off_the_dask_workers(own_cache):
    """Multi-start on a Dask client ships the problem without its local caches: the compiled copies are
    libraries loaded in this process (a worker elsewhere has no such file); everything a solve adds is local."""
    from ocp_constraints.ocp.multistart import LOCAL_CACHES

    problem = _swing_up("always")
    before = set(problem.__dict__)
    problem.solve(oc.Radau(5, degree=3))
    gained = {k for k in set(problem.__dict__) - before if k.startswith("_")}
    assert "_machine_code" in gained and gained <= set(LOCAL_CACHES) | {"_auto_coordinates"}
