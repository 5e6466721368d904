"""Interrupted runs (issue 17): SIGINT and SIGTERM sent to a real ``ocp-constraints simulate`` process
mid-run write what was computed, with ``"success": false`` and the reason; in-process, ``simulate`` keeps
its complete samples and an IPOPT solve reports the interruption instead of a failure.

Expected values are independent of the code's output: the exit status is the shell's 128 + signal
number, the written samples are checked against each other (CSV rows, ``t_reached``, the dt grid)
and against the physics (the constraint residuals of every written state)."""
from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.errors import RunInterrupted
from ocp_constraints.output.run_folder import MANIFEST, STAGING_PREFIX
from ocp_constraints.output.signals import call_interruptibly

T_FINAL = 1000.0   # far longer than the test waits: the signal always lands mid-run


def _interrupt_cli(out, sig) -> tuple[int, str]:
    proc = subprocess.Popen([sys.executable, "-m", "ocp_constraints", "simulate", "whirling", "--t-final", str(T_FINAL),
                             "--out", str(out), "--no-plots"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "MPLBACKEND": "Agg"})
    try:
        first = proc.stderr.readline()           # printed when the integration starts
        assert first.startswith("simulating whirling: t = 0 ... 1000 s, 100,001 samples"), first
        time.sleep(1.0)                          # let it integrate a while (no timing is asserted)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, first + err


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_mid_run_writes_what_was_computed(tmp_path, sig):
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text('{"software": {"ocp_constraints": "0"}, "plots": ["energy.png"]}')
    (out / "energy.png").write_bytes(b"a plot of an earlier run")   # the interrupted run replaces that run
    code, err = _interrupt_cli(out, sig)
    name = signal.Signals(sig).name
    assert code == 128 + int(sig), err
    assert f"interrupted by {name}" in err and "Traceback" not in err and str(out) in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] is False and summary["status"] == f"interrupted by {name}"
    assert 0.0 < summary["t_reached"] < T_FINAL
    rows = list(csv.DictReader(open(out / "trajectory.csv")))
    loads = list(csv.DictReader(open(out / "loads.csv")))
    assert len(rows) == len(loads) == summary["samples"]
    t = np.array([float(r["t"]) for r in rows])
    np.testing.assert_allclose(t, 0.01 * np.arange(len(t)), rtol=0, atol=1e-12)   # every sample, on the dt grid
    assert t[-1] == pytest.approx(summary["t_reached"], abs=1e-12)
    assert all(np.isfinite(float(v)) for r in loads for v in r.values())
    # What was written is physics, not a torn record: every written state satisfies the constraints.
    scene = oc.build_scene("whirling")
    eqs = oc.SystemEquations(scene.model)
    cols = [r for r in rows]
    q = np.array([[float(r[n]) for n in scene.model.coordinate_names] for r in cols])
    u = np.array([[float(r[n]) for n in scene.model.speed_names] for r in cols])
    for k in range(0, len(t), max(1, len(t) // 20)):
        _, _, phi, pi, _ = eqs.constraint_functions(q[k], u[k], t[k], [])
        assert np.abs(np.asarray(phi)).max() < 1e-8 and np.abs(np.asarray(pi)).max() < 1e-8
    # The folder holds this run only: no plots of the earlier run, no staging folder, the manifest says so.
    assert not list(out.glob("*.png")) and not list(out.glob("*.html")) and not list(out.glob(f"{STAGING_PREFIX}*"))
    visible = {p.name for p in out.iterdir() if not p.name.startswith(".")}
    assert set(json.loads((out / MANIFEST).read_text())["files"]) == visible
    assert {"loads.csv", "summary.json", "trajectory.csv"} <= visible


def test_ctrl_c_in_simulate_keeps_every_complete_sample():
    """Library use (Python's own SIGINT handler): ``simulate`` raises a KeyboardInterrupt that carries the run."""
    scene = oc.build_scene("pendulum")
    eqs = oc.SystemEquations(scene.model)
    q0, u0 = oc.consistent_state(eqs, scene.coordinates, scene.rates)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt) as info:
            oc.simulate(eqs, q0, u0, T_FINAL)
    finally:
        timer.cancel()
    exc = info.value
    assert isinstance(exc, RunInterrupted) and exc.signal_name == "SIGINT"
    traj = exc.partial
    assert traj.success is False and traj.status == "interrupted by SIGINT"
    n = len(traj)
    assert n >= 1 and traj.q.shape == (n, eqs.nq) and traj.lam.shape == (n, eqs.nc)
    np.testing.assert_allclose(traj.t, 0.01 * np.arange(n), atol=1e-12)
    pos, vel = traj.residuals()
    assert pos < 1e-8 and vel < 1e-8


class _SigintAtIteration(ca.Callback):
    """IPOPT iteration callback that sends SIGINT to this process at a given iteration, so the
    signal lands while IPOPT runs (no timing involved)."""

    def __init__(self, nx: int, at: int):
        ca.Callback.__init__(self)
        self.nx, self.at, self.calls = nx, at, 0
        self.construct("sigint_at_iteration", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        return ca.Sparsity.dense(self.nx if name in ("x", "lam_x") else (1 if name == "f" else 0), 1)

    def eval(self, arg):
        self.calls += 1
        if self.calls == self.at:
            os.kill(os.getpid(), signal.SIGINT)
        return [0]


def test_ctrl_c_during_ipopt_is_an_interruption_not_a_failure():
    """CasADi 3.8's nlpsol swallows a KeyboardInterrupt raised while IPOPT runs (it returns with a
    status: NonIpopt_Exception_Thrown for a signal in IPOPT's own code, User_Requested_Stop in a
    callback); ``call_interruptibly`` (used by the knee's solves) raises it as RunInterrupted."""
    x = ca.SX.sym("x", 50)
    f = ca.sumsqr(x[1:] - x[:-1] ** 2) + ca.sumsqr(1 - x)
    kick = _SigintAtIteration(50, at=3)
    solver = ca.nlpsol("s", "ipopt", {"x": x, "f": f}, {"ipopt.print_level": 0, "print_time": False,
                                                         "ipopt.sb": "yes", "iteration_callback": kick})
    with pytest.raises(RunInterrupted) as info:
        call_interruptibly(solver, x0=-1.2)
    assert info.value.signal_name == "SIGINT"
    assert not solver.stats()["success"] and kick.calls == 3   # stopped where the signal came
