"""The bad-input catalogue (issue 17): what a new user gets for a wrong input, class by class.

Each class is one test, parametrized over its examples (``CATALOGUE``). A case is what the user does
and what must come back: an error of :mod:`ocp_constraints.errors` (its type is asserted, and that
its message names the culprit), the command line's exit status 2 with one ``error:`` line naming
it, or, for inputs that used to give silently wrong results, the right result (checked against an
independent value). A raw CasADi, NumPy or LAPACK error fails a case, and so does a run that
returns without a word. ``python scripts/bad_input_table.py`` runs these cases and prints the
README's table from them, so the table stays what the code does.
"""
from __future__ import annotations

import csv
import io
import json
import os
import re
import stat
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints import errors as E
from ocp_constraints import joints
from ocp_constraints.biomech.opensim_files import read_motion
from ocp_constraints.cli.main import main

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim-gait2354-subject01"
MANIFEST = ".ocp-constraints-run.json"   # ocp_constraints.output.run_folder.MANIFEST, the contract's file name


# -- the form of a case ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """``does``: what the user does; ``run`` does it; ``expect``: the error class, the CLI exit status,
    or a check of the result that returns what the user gets; ``names``: what the message must name."""

    does: str
    run: Callable[[], object]
    expect: object
    names: tuple[str, ...] = ()


@dataclass(frozen=True)
class CliRun:
    code: int
    out: str
    err: str


def cli(*argv: str) -> CliRun:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main([str(a) for a in argv])
    return CliRun(code, out.getvalue(), err.getvalue())


def outcome(case: Case) -> str:
    """Run ``case``; return what the user gets (one line) or raise AssertionError saying what is wrong."""
    if isinstance(case.expect, type):
        try:
            case.run()
        except Exception as exc:  # noqa: BLE001 - we classify what came back
            where = type(exc).__module__
            assert where == "ocp_constraints.errors", f"raw {where}.{type(exc).__name__}: {exc}"
            assert isinstance(exc, case.expect), f"{type(exc).__name__} instead of {case.expect.__name__}: {exc}"
            missing = [n for n in case.names if n not in str(exc)]
            assert not missing, f"message does not name {missing}: {exc}"
            return f"`{type(exc).__name__}`: {exc}"
        raise AssertionError("silent: no error")
    if isinstance(case.expect, int):
        r = case.run()
        assert "Traceback" not in r.err, f"raw: a traceback, exit {r.code}: {r.err[-300:]}"
        assert r.code != 0, f"silent: exit 0, stderr {r.err!r}"
        lines = [ln for ln in r.err.splitlines() if ln.startswith("error:")]
        assert r.code == case.expect and len(lines) == 1, f"exit {r.code}, stderr {r.err!r}"
        missing = [n for n in case.names if n not in lines[0]]
        assert not missing, f"message does not name {missing}: {lines[0]}"
        return f"exit {r.code}, `{lines[0]}`"
    return case.expect(case.run())


def _id(case: Case) -> str:
    return re.sub(r"[^a-zA-Z0-9]+", "-", case.does).strip("-")[:60]


# -- shared pieces (built once) -----------------------------------------------------------------------
@lru_cache(maxsize=None)
def scene_state(name: str):
    scene = oc.build_scene(name)
    eqs = oc.SystemEquations(scene.model)
    q0, u0 = oc.consistent_state(eqs, scene.coordinates, scene.rates)
    return scene, eqs, q0, u0


def simulate_scene_state(name: str, dq=None, du=None, t_final: float = 0.05, **kw):
    _, eqs, q0, u0 = scene_state(name)
    q = q0 if dq is None else q0 + np.asarray(dq, float)
    u = u0 if du is None else u0 + np.asarray(du, float)
    return oc.simulate(eqs, q, u, t_final, **kw)


def rod(J=(0.1, 0.1, 0.1), rotation="321", name="m"):
    model = oc.Model(name)
    body = model.add_body("rod", 1.0, np.diag(J), rotation=rotation)
    return model, body, body.point("A", [0.0, 0.5, 0.0])


def hanging_state(model, rates=None, inputs=None):
    eqs = oc.SystemEquations(model)
    coords = {n: 0.0 for n in model.coordinate_names}
    coords["rod.y"] = -0.5
    q0, u0 = oc.consistent_state(eqs, coords, rates or {}, inputs=inputs)
    return eqs, q0, u0


def hinged_rod(J=(0.1, 0.1, 0.1)):
    model, body, A = rod(J)
    joints.revolute(model, "hinge", A, axis=(0, 0, 1))
    return model, body, A


def motor_rod():
    model, body, A = hinged_rod()
    model.add_torque("motor", body, ca.vertcat(0, 0, model.add_input("motor")))
    eqs, q0, u0 = hanging_state(model, inputs=[0.0])
    return eqs, q0, u0


def unit(k):
    e = np.zeros(6)
    e[k] = 1.0
    return e


def scene_file(tmp: Path, body: str, name: str = "user_scene.py") -> Path:
    path = tmp / name
    path.write_text("import numpy as np\nfrom ocp_constraints import Model, Scene\nDEFAULTS = {'mass': 1.0}\n" + body)
    return path


def in_tmp(fn: Callable[[Path], object]) -> Callable[[], object]:
    def run():
        with tempfile.TemporaryDirectory() as d:
            return fn(Path(d))
    return run


# -- checks of results that used to be silently wrong ---------------------------------------------------
def ends_at(t_final: float, samples: int):
    def check(traj) -> str:
        assert traj.t[-1] == t_final and len(traj) == samples, (traj.t[-3:], len(traj))
        assert np.all(np.diff(traj.t) > 0)
        return f"samples every dt and at t = {t_final:g} s exactly ({samples} samples; the last step is shorter)"
    return check


def cli_run_ends_at(t_final: float):
    def check(files: dict) -> str:
        rows = files["trajectory.csv"]
        assert float(rows[-1]["t"]) == pytest.approx(t_final, abs=1e-15), rows[-1]["t"]
        assert json.loads(files["summary.json"])["t_reached"] == pytest.approx(t_final, abs=1e-15)
        return f"exit 0; trajectory.csv ends at t = {t_final:g} s"
    return check


def simulate_cli_files(*args):
    def fn(tmp: Path):
        out = tmp / "out"
        r = cli("simulate", *args, "--out", out, "--no-plots")
        assert r.code == 0, r.err
        return {"trajectory.csv": list(csv.DictReader(open(out / "trajectory.csv"))),
                "summary.json": (out / "summary.json").read_text()}
    return in_tmp(fn)


_FIRST_RUN = tempfile.TemporaryDirectory()


@lru_cache(maxsize=None)
def first_run_with_plots() -> Path:
    """One ``simulate --out`` with plots under umask 002 (made once: the rerun cases work on copies of
    it, the permissions case reads its modes)."""
    out = Path(_FIRST_RUN.name) / "first"
    old = os.umask(0o002)
    try:
        assert cli("simulate", "pendulum", "--t-final", "0.02", "--out", out).code == 0
    finally:
        os.umask(old)
    return out


def modes_of_first_run():
    return {p.name: stat.S_IMODE(p.stat().st_mode) for p in first_run_with_plots().iterdir()}


def rerun(second: tuple, own_file: bool = False, legacy: bool = False):
    """A folder holding a run with plots (and the user's files), then ``simulate`` into it again; returns
    the folder's file names before and after, and the manifest's list."""
    def fn(tmp: Path):
        import shutil

        out = tmp / "out"
        shutil.copytree(first_run_with_plots(), out)
        if own_file:
            (out / "notes.txt").write_text("the user's own notes")
            (out / "loads_mine.png").write_bytes(b"the user's own picture")
        before = sorted(p.name for p in out.iterdir())
        if legacy:   # a folder written before manifests existed: only its summary.json says what is ours
            (out / MANIFEST).unlink(missing_ok=True)
        assert cli("simulate", *second, "--out", out).code == 0
        manifest = json.loads((out / MANIFEST).read_text())["files"] if (out / MANIFEST).exists() else None
        return before, sorted(p.name for p in out.iterdir()), manifest
    return in_tmp(fn)


def holds_only_the_new_run(keep: tuple = ()):
    def check(result) -> str:
        before, after, manifest = result
        plots = {n for n in before if n.endswith((".png", ".html")) and n not in keep}
        assert plots, before                                   # the first run had plots (and a report)
        visible = {n for n in after if not n.startswith(".")}
        assert not plots & visible, sorted(plots & visible)    # none of them is left
        assert {"loads.csv", "summary.json", "trajectory.csv"} <= visible
        assert manifest is not None and visible == set(manifest) | set(keep), (sorted(visible), manifest)
        return ("the previous run's " + ", ".join(sorted(plots)) + " are removed; the folder holds "
                + ", ".join(sorted(visible)) + (" (the user's own files stay)" if keep else ""))
    return check


def mode_under_umask(mask: int, *args: str):
    def fn(tmp: Path):
        old = os.umask(mask)
        try:
            assert cli("simulate", "pendulum", "--t-final", "0.02", "--out", tmp / "o", *args).code == 0
        finally:
            os.umask(old)
        return {p.name: stat.S_IMODE(p.stat().st_mode) for p in (tmp / "o").iterdir()}
    return in_tmp(fn)


def modes_are(expected: int):
    def check(modes: dict) -> str:
        assert modes and all(m == expected for m in modes.values()), {k: oct(v) for k, v in modes.items()}
        return f"every result file has mode {expected:o} (0666 & ~umask, as open() gives)"
    return check


def nothing_written(result) -> str:
    code, err, listing = result
    assert code == 2 and "GB" in err and "samples" in err and listing == ["summary.json"], (code, err, listing)
    return f"exit 2 before any computing, the folder is left as it was: `{err.strip()}`"


def refused_run_keeps_folder(tmp: Path):
    out = tmp / "o"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    r = cli("simulate", "whirling", "--t-final", "1e6", "--out", out)
    return r.code, r.err, sorted(p.name for p in out.iterdir())


def estimate_matches_tracemalloc(_) -> str:
    """The memory formula against tracemalloc's peak growth between two run lengths (an independent
    measure): the samples of ``simulate`` and the writing of their results files."""
    import tracemalloc

    from ocp_constraints.dynamics.preflight import samples_memory
    from ocp_constraints.scenes.tasks import write_trajectory_results

    scene, eqs, q0, u0 = scene_state("pendulum")
    opts = oc.SimulationOptions(dt=0.002)
    oc.simulate(eqs, q0, u0, 0.01, opts)   # CasADi functions built before measuring
    peaks = {}
    for t_final in (0.1, 0.4):
        with tempfile.TemporaryDirectory() as d:
            tracemalloc.start()
            traj = oc.simulate(eqs, q0, u0, t_final, opts)
            write_trajectory_results(d, traj, {"joints": []}, {}, plots=False)
            peaks[len(traj)] = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            del traj
    (n1, p1), (n2, p2) = sorted(peaks.items())
    measured = (p2 - p1) / (n2 - n1)
    formula = samples_memory(eqs, 1)
    assert 0.67 < formula / measured < 1.5, (formula, measured)
    return f"the estimate ({formula} bytes a sample for the pendulum) is within 1.5x of tracemalloc's ({measured:.0f})"


def mat_file(tmp: Path, content) -> Path:
    path = tmp / "motion.mat"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        import scipy.io

        scipy.io.savemat(str(path), content)
    return path


def read_mat(content):
    return in_tmp(lambda tmp: read_motion(mat_file(tmp, content)))


def gait_with_mat(content):
    def fn(tmp: Path):
        return cli("gait", "--model", SHARED / "subject01_simbody.osim", "--motion", mat_file(tmp, content),
                   "--grf", SHARED / "subject01_walk1_grf.mot", "--out", tmp / "o")
    return in_tmp(fn)


def scene_cli(body: str, *args):
    return in_tmp(lambda tmp: cli("simulate", scene_file(tmp, body), "--t-final", "0.02", *args))


def task_cli(body: str):
    return in_tmp(lambda tmp: cli("solve", scene_file(tmp, body)))


def redundant_with(extra: Callable):
    def run():
        model, body, A = hinged_rod()
        extra(model, body, A)
        hanging_state(model)
    return run


def redundant_ocp():
    """A swing-up whose hinge also has a ball-and-socket: the optimal-control path (its start's projection met a
    singular matrix and NumPy's bare LinAlgError, a sixth newcomer's four-bar closed by a second revolute)."""
    model, body, A = hinged_rod()
    joints.ball_and_socket(model, "ball", A)
    model.add_torque("motor", body, ca.vertcat(0, 0, model.add_input("tau")))
    problem = oc.OptimalControlProblem(model, t_final=1.0)
    problem.initial({"rod.psi": 0.0, "rod.omega_z": 0.0})
    problem.final({"rod.psi": 1.0, "rod.omega_z": 0.0})
    problem.minimize_effort()
    problem.solve(oc.Radau(5, degree=3))


# -- the catalogue -----------------------------------------------------------------------------------------
_S = "Silent wrong before"
_R = "Raw error before"
_N = "Named before (kept)"

def rod_ocp() -> "oc.OptimalControlProblem":
    """A hinged rod with a motor, turned from rest at psi = 0 to rest at psi = 1 rad in 1 s."""
    model, body, _ = hinged_rod()
    model.add_torque("motor", body, ca.vertcat(0, 0, model.add_input("motor")))
    problem = oc.OptimalControlProblem(model, t_final=1.0)
    problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    problem.final({"rod.psi": 1.0, "rod.psi_dot": 0.0})
    return problem


def rod_ocp_313() -> "oc.OptimalControlProblem":
    """The rod of :func:`rod_ocp` on the default Euler sequence 3-1-3, whose psi and phi turn about one
    axis at theta = 0: the hinge fixes their sum only, so phi is undetermined, and the message says why."""
    model = oc.Model("m")
    body = model.add_body("rod", 1.0, np.diag([0.1, 0.1, 0.1]))
    joints.revolute(model, "hinge", body.point("A", [0.0, 0.5, 0.0]), axis=(0, 0, 1))
    model.add_torque("motor", body, ca.vertcat(0, 0, model.add_input("motor")))
    problem = oc.OptimalControlProblem(model, t_final=1.0)
    problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    problem.final({"rod.psi": 1.0, "rod.psi_dot": 0.0})
    return problem


def with_rod_ocp(edit: Callable) -> Callable[[], object]:
    return lambda: edit(rod_ocp())


def quaternion_ball_ocp_three_components():
    """A body on a quaternion on a hand-written ball joint, its initial orientation given by qx, qy, qz
    only, a final one by qx, qy, qz: |q| was free, and IPOPT returned 0.0002 for an optimum of 1.4952
    (issue 13); then the pre-solve check refused it; now the NLP holds |q| = 1 at every point."""
    model = oc.Model("q", gravity=(0.0, 0.0, -9.81))
    bob = model.add_body("bob", 1.0, np.diag([1 / 12, 1 / 12, 0.01]), rotation="quaternion")
    P = bob.point("P", (0.0, 0.0, 0.5))
    for k in range(3):
        model.add_constraint(f"ball.v{k + 1}", ca.dot(ca.DM.eye(3)[:, k], P.v), joint="ball", position=P.position[k])
    model.add_torque("motor", bob, ca.vertcat(*[model.add_input(f"t{c}") for c in "xyz"]))
    problem = oc.OptimalControlProblem(model, t_final=2.0)
    problem.initial({"bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0, **{f"bob.omega_{c}": 0.0 for c in "xyz"}})
    problem.final({"bob.qx": 0.35438937171419277, "bob.qy": 0.2968801535759501, "bob.qz": 0.1782412788480126,
                   **{f"bob.omega_{c}": 0.0 for c in "xyz"}})
    problem.minimize_effort()
    # qx, qy, qz fixed leave qw's sign free, another rotation each: warned since session 32 (ocp/boundary_poses.py).
    with pytest.warns(oc.AmbiguousPoseWarning, match=r"Body 'bob' \(bob.qx, bob.qy, bob.qz fixed\): bob.qw = "):
        return problem.solve(oc.Radau(5, degree=7))


def unit_quaternion_turn(sol) -> str:
    """|q| = 1 at every point and the final qw that a unit quaternion with the given qx, qy, qz has; the
    optimum against another parameterization is tests/test_ocp_quaternions.py's."""
    q = np.vstack([sol.sample(f"bob.q{c}") for c in "wxyz"])
    assert np.abs(np.linalg.norm(q, axis=0) - 1.0).max() < 1e-9, np.linalg.norm(q, axis=0)
    assert abs(q[0, -1]) == pytest.approx(0.8686198214082874, abs=1e-9)
    return f"solved: |q| = 1 at every point, objective {sol.objective:.4f}"


CATALOGUE: dict[str, tuple[str, str, list[Case]]] = {
    "state_off_constraints": ("simulate(eqs, q0, u0) from a state off the constraints", _S, [
        Case("simulate(eqs, q0 + 0.1, u0): coordinates off the hinge (pendulum)",
             lambda: simulate_scene_state("pendulum", dq=0.1), E.InconsistentStateError, ("q0", "hinge.v", "consistent_state")),
        Case("simulate(...) with rod.x moved 1 mm off the hinge", lambda: simulate_scene_state("pendulum", dq=1e-3 * unit(0)),
             E.InconsistentStateError, ("'hinge.v1'", "position level")),
        Case("simulate(eqs, q0, u0 + 0.1): speeds off the hinge", lambda: simulate_scene_state("pendulum", du=0.1),
             E.InconsistentStateError, ("u0", "hinge.", "consistent_state")),
        Case("simulate(...) with the whirling body spun 1 rad/s faster than the motor", lambda: simulate_scene_state(
            "whirling", du=np.r_[0, 0, 0, 0, 0, 1.0]), E.InconsistentStateError, ("shaft.drive",)),
        Case("simulate(...) with the sliding disk lifted 1 cm", lambda: simulate_scene_state("sliding_disk", dq=0.01 * unit(2)),
             E.InconsistentStateError, ("contact.n",)),
    ]),
    "time_grid": ("the time grid: dt and t_final", _S, [
        Case("simulate(..., t_final=0.105) with dt = 0.01 (not a multiple)", lambda: simulate_scene_state("pendulum", t_final=0.105),
             ends_at(0.105, 12)),
        Case("simulate(..., t_final=0.1, dt=0.03)", lambda: simulate_scene_state(
            "pendulum", t_final=0.1, options=oc.SimulationOptions(dt=0.03)), ends_at(0.1, 5)),
        Case("simulate --t-final 0.55 --dt 0.2", simulate_cli_files("pendulum", "--t-final", "0.55", "--dt", "0.2"),
             cli_run_ends_at(0.55)),
        Case("simulate(..., t_final=0.1) with dt = 0.3 (dt longer than the run)", lambda: simulate_scene_state(
            "pendulum", t_final=0.1, options=oc.SimulationOptions(dt=0.3)), E.ModelError, ("dt = 0.3", "0.1")),
        Case("simulate pendulum --dt 1 --t-final 0.5", lambda: cli("simulate", "pendulum", "--dt", "1", "--t-final", "0.5"),
             2, ("dt = 1", "0.5")),
        Case("simulate(..., t_final=-1)", lambda: simulate_scene_state("pendulum", t_final=-1.0), E.ModelError, ("t_final",)),
        Case("SimulationOptions(dt=0)", lambda: simulate_scene_state("pendulum", options=oc.SimulationOptions(dt=0.0)),
             E.ModelError, ("'dt'", "positive")),
        Case("SimulationOptions(dt=nan)", lambda: simulate_scene_state("pendulum", options=oc.SimulationOptions(dt=float("nan"))),
             E.ModelError, ("'dt'",)),
        Case("SimulationOptions(method='rk4')", lambda: simulate_scene_state("pendulum", options=oc.SimulationOptions(method="rk4")),
             E.ModelError, ("'method'", "adams")),
    ]),
    "degree_without_radau": ("--degree with a scheme that has no degree", _S, [
        Case("solve pendulum --scheme trapezoidal --degree 5", lambda: cli("solve", "pendulum", "--scheme", "trapezoidal",
                                                                           "--degree", "5"), 2, ("--degree 5", "trapezoidal", "radau")),
        Case("solve pendulum --scheme hermite-simpson --degree 2", lambda: cli("solve", "pendulum", "--scheme", "hermite-simpson",
                                                                               "--degree", "2"), 2, ("--degree 2", "hermite-simpson")),
    ]),
    "rerun_into_out": ("a rerun into an existing --out", _S, [
        Case("simulate with plots, then again --no-plots, into one folder",
             rerun(("pendulum", "--t-final", "0.02", "--no-plots")), holds_only_the_new_run()),
        Case("the same, into a folder that also holds the user's own files",
             rerun(("pendulum", "--t-final", "0.02", "--no-plots"), own_file=True),
             holds_only_the_new_run(keep=("loads_mine.png", "notes.txt"))),
        Case("the same, into a folder written before manifests existed",
             rerun(("pendulum", "--t-final", "0.02", "--no-plots"), legacy=True),
             holds_only_the_new_run()),
        Case("simulate --out a_file (a file, not a folder)", in_tmp(lambda tmp: (tmp / "f").write_text("x") and cli(
            "simulate", "pendulum", "--out", tmp / "f")), 2, ("exists and is not a folder",)),
        Case("simulate --out under a file (unwritable)", in_tmp(lambda tmp: (tmp / "f").write_text("x") and cli(
            "simulate", "pendulum", "--out", tmp / "f" / "sub")), 2, ("cannot write results",)),
    ]),
    "file_permissions": ("permissions of the result files", _S, [
        Case("simulate --out --no-plots under umask 022", mode_under_umask(0o022, "--no-plots"), modes_are(0o644)),
        Case("simulate --out (with plots) under umask 002 (group-writable)", modes_of_first_run, modes_are(0o664)),
        Case("simulate --out --no-plots under umask 077 (private)", mode_under_umask(0o077, "--no-plots"), modes_are(0o600)),
    ]),
    "non_finite": ("NaN or inf in an expression, a parameter or an input", _R, [
        Case("add_constraint('c', A.v[0] + nan)", lambda: (lambda m, b, A: m.add_constraint("c", A.v[0] + float("nan")))(*rod()),
             E.ModelError, ("constraint 'c'", "nan")),
        Case("add_constraint('c', inf * rod.omega[2])", lambda: (lambda m, b, A: m.add_constraint("c", float("inf") * b.omega[2]))(
            *rod()), E.ModelError, ("constraint 'c'", "inf")),
        Case("add_constraint(..., position=nan * rod.q[0])", lambda: (lambda m, b, A: m.add_constraint(
            "c", A.v[0], position=float("nan") * b.q[0]))(*rod()), E.ModelError, ("constraint 'c'", "position form")),
        Case("joints.driven_axis(..., rate=nan)", lambda: (lambda m, b, A: joints.driven_axis(m, "shaft", b, float("nan")))(
            *rod(rotation="313")), E.ModelError, ("joint 'shaft'", "rate")),
        Case("add_force('push', A, [0, 0, nan])", lambda: (lambda m, b, A: m.add_force("push", A, [0, 0, float("nan")]))(*rod()),
             E.ModelError, ("force 'push'", "nan")),
        Case("a constraint 1/x at x = 0 (NaN at the initial state)", lambda: (lambda m, b, A: (
            m.add_constraint("c", b.vbar[0] / b.q[0]), hanging_state(m)))(*rod()), E.ModelError, ("'c'", "NaN or inf")),
        Case("simulate(..., inputs=lambda t: [nan])", lambda: oc.simulate(*motor_rod(), 0.05, inputs=lambda t: [float("nan")]),
             E.ModelError, ("'motor'", "not finite")),
        Case("simulate(..., inputs=lambda t: [inf if t > 0.02 else 0])", lambda: oc.simulate(
            *motor_rod(), 0.05, inputs=lambda t: [float("inf") if t > 0.02 else 0.0]), E.ModelError, ("'motor'", "t = 0.03")),
        Case("simulate whirling --param omega=nan", lambda: cli("simulate", "whirling", "--param", "omega=nan"), 2,
             ("'omega'", "finite")),
        Case("simulate whirling --param omega=inf", lambda: cli("simulate", "whirling", "--param", "omega=inf"), 2,
             ("'omega'", "finite")),
        Case("Model('m', gravity=(0, 0, nan))", lambda: oc.Model("m", gravity=(0, 0, float("nan"))), E.ModelError, ("gravity",)),
        Case("body.point('P', [0, nan, 0])", lambda: rod()[1].point("P", [0, float("nan"), 0]), E.ModelError, ("rod.P",)),
    ]),
    "singular_mass_matrix": ("a zero inertia about an axis no constraint fixes", _R, [
        Case("a thin rod (J = diag(0.1, 0, 0.1)) on a ball-and-socket, simulated", lambda: (lambda m, b, A: (
            joints.ball_and_socket(m, "socket", A), oc.simulate(*hanging_state(m), 0.05)))(*rod((0.1, 0.0, 0.1))),
            E.ModelError, ("body 'rod'", "(0, 1, 0)", "fixed_angle")),
        Case("a free body with J = diag(0, 0.1, 0.1), simulated", lambda: (lambda m, b, A: oc.simulate(
            *hanging_state(m), 0.05))(*rod((0.0, 0.1, 0.1))), E.ModelError, ("body 'rod'", "(1, 0, 0)")),
    ]),
    "shape": ("q0, u0 or inputs of the wrong length or shape", _R, [
        Case("simulate(eqs, q0[:3], u0, 1)", lambda: (lambda s, e, q, u: oc.simulate(e, q[:3], u, 0.05))(*scene_state("pendulum")),
             E.ModelError, ("q0", "(3,)", "rod.x", "6 coordinates")),
        Case("simulate(eqs, np.r_[q0, 0], u0, 1)", lambda: (lambda s, e, q, u: oc.simulate(e, np.r_[q, 0], u, 0.05))(
            *scene_state("pendulum")), E.ModelError, ("q0", "(7,)")),
        Case("simulate(eqs, q0, u0.reshape(2, 3), 1)", lambda: (lambda s, e, q, u: oc.simulate(e, q, u.reshape(2, 3), 0.05))(
            *scene_state("pendulum")), E.ModelError, ("u0", "(2, 3)", "rod.omega_z")),
        Case("simulate(eqs, 'q0', u0, 1)", lambda: (lambda s, e, q, u: oc.simulate(e, "q0", u, 0.05))(*scene_state("pendulum")),
             E.ModelError, ("q0", "6 numbers")),
        Case("simulate(eqs, q0 with a NaN, u0, 1)", lambda: (lambda s, e, q, u: oc.simulate(
            e, np.where(np.arange(6) == 4, np.nan, q), u, 0.05))(*scene_state("pendulum")), E.ModelError, ("rod.theta",)),
        Case("simulate(..., inputs=lambda t: [0, 0]) for one input", lambda: oc.simulate(*motor_rod(), 0.05, inputs=lambda t: [0, 0]),
             E.ModelError, ("'m'", "1 input", "motor")),
        Case("simulate(..., inputs=np.zeros(1)) (an array, not a function)", lambda: oc.simulate(
            *motor_rod(), 0.05, inputs=np.zeros(1)), E.ModelError, ("inputs must be a function", "motor")),
        Case("simulate(...) without inputs for a model with an input", lambda: oc.simulate(*motor_rod(), 0.05), E.ModelError,
             ("motor", "pass inputs(t)")),
        Case("consistent_state(..., inputs=[0, 0]) for one input", lambda: hanging_state(hinged_rod()[0], inputs=[0.0, 0.0]),
             E.ModelError, ("inputs", "0 input")),
        Case("consistent_state with a coordinate missing", lambda: (lambda s, e, q, u: oc.consistent_state(
            e, {k: v for k, v in s.coordinates.items() if k != "rod.z"}, {}))(*scene_state("pendulum")), E.ModelError, ("rod.z",)),
        Case("consistent_state with an unknown rate 'rod.spin'", lambda: (lambda s, e, q, u: oc.consistent_state(
            e, s.coordinates, {"rod.spin": 1.0}))(*scene_state("pendulum")), E.ModelError, ("rod.spin",)),
        Case("consistent_state with rates the hinge forbids (omega_x = 1)", lambda: (lambda s, e, q, u: oc.consistent_state(
            e, s.coordinates, {"rod.omega_x": 1.0}))(*scene_state("pendulum")), E.InconsistentStateError, ("rod.omega_x",)),
    ]),
    "foreign_point": ("a point or body of another body or model", _R, [
        Case("add_force('f', P) with P of a body of another model", lambda: (lambda m, b, A: m.add_force(
            "f", rod(name="other")[2], [0, 0, 1]))(*rod()), E.ModelError, ("force 'f'", "rod.A", "model 'm'", "different body")),
        Case("add_force('f', P) with P of a Body made outside any model", lambda: (lambda m, b, A: m.add_force(
            "f", oc.Body("loose", 1.0, np.eye(3) * 0.1).point("P", [0, 0, 0]), [0, 0, 1]))(*rod()), E.ModelError,
             ("force 'f'", "body 'loose' is not in model 'm'")),
        Case("add_torque('t', body) with a body of another model", lambda: (lambda m, b, A: m.add_torque(
            "t", rod(name="other")[1], [0, 0, 1]))(*rod()), E.ModelError, ("torque 't'", "rod")),
        Case("add_torque(..., reaction_body=a body of another model)", lambda: (lambda m, b, A: m.add_torque(
            "t", b, [0, 0, 1], reaction_body=rod(name="other")[1]))(*rod()), E.ModelError, ("reaction_body",)),
        Case("add_constraint(..., point=P) with P of another model", lambda: (lambda m, b, A: m.add_constraint(
            "c", A.v[0], point=rod(name="other")[2]))(*rod()), E.ModelError, ("constraint 'c'", "point= rod.A")),
        Case("add_constraint(..., point=P) with P on a body the constraint does not involve", lambda: (lambda m, b, A: (
            m.add_body("b2", 1.0, np.eye(3) * 0.1), m.add_constraint("c", A.v[0], point=m.bodies["b2"].point("P", [0, 0, 0]))))(
            *rod()), E.ModelError, ("constraint 'c'", "b2.P", "does not involve")),
        Case("add_constraint with a velocity of another model's point", lambda: (lambda m, b, A: m.add_constraint(
            "c", rod(name="other")[2].v[0]))(*rod()), E.ModelError, ("constraint 'c'", "rod.A.v")),
        Case("add_force('f', 'A') (a name, not a point)", lambda: (lambda m, b, A: m.add_force("f", "A", [0, 0, 1]))(*rod()),
             E.ModelError, ("force 'f'", "Point")),
    ]),
    "angle_index": ("an Euler-angle index out of 1..3", _R, [
        Case("joints.fixed_angle(..., index=4)", lambda: (lambda m, b, A: joints.fixed_angle(m, "lock", b, index=4))(*rod()),
             E.ModelError, ("joint 'lock'", "1, 2 or 3", "got 4")),
        Case("joints.fixed_angle(..., index=0) (was the third angle, silently)", lambda: (lambda m, b, A: joints.fixed_angle(
            m, "lock", b, index=0))(*rod()), E.ModelError, ("joint 'lock'", "got 0")),
        Case("joints.fixed_angle(..., index=-1)", lambda: (lambda m, b, A: joints.fixed_angle(m, "lock", b, index=-1))(*rod()),
             E.ModelError, ("got -1",)),
        Case("joints.fixed_angle(..., index=1.5)", lambda: (lambda m, b, A: joints.fixed_angle(m, "lock", b, index=1.5))(*rod()),
             E.ModelError, ("got 1.5",)),
        Case("joints.driven_axis(..., index=4)", lambda: (lambda m, b, A: joints.driven_axis(m, "shaft", b, 2.0, index=4))(
            *rod(rotation="313")), E.ModelError, ("joint 'shaft'", "psi", "got 4")),
        Case("joints.fixed_angle on a quaternion body", lambda: (lambda m, b, A: joints.fixed_angle(m, "lock", b, index=1))(
            *rod(rotation="quaternion")), E.ModelError, ("body 'rod'", "Euler")),
    ]),
    "callable_for_expression": ("a Python function where an expression is expected", _R, [
        Case("joints.driven_axis(..., rate=lambda t: 2.0)", lambda: (lambda m, b, A: joints.driven_axis(
            m, "shaft", b, lambda t: 2.0))(*rod(rotation="313")), E.ModelError, ("joint 'shaft'", "Python function", "model.t")),
        Case("joints.sliding_contact(..., rate=lambda t: 0.0)", lambda: (lambda m, b, A: joints.sliding_contact(
            m, "floor", A, rate=lambda t: 0.0))(*rod()), E.ModelError, ("joint 'floor'", "Python function")),
        Case("joints.rolling_contact(..., surface_velocity=lambda t: ...)", lambda: (lambda m, b, A: joints.rolling_contact(
            m, "belt", A, surface_velocity=lambda t: [1, 0, 0]))(*rod()), E.ModelError, ("joint 'belt'", "surface_velocity")),
        Case("add_force('f', A, lambda t: [0, 0, 1])", lambda: (lambda m, b, A: m.add_force("f", A, lambda t: [0, 0, 1]))(*rod()),
             E.ModelError, ("force 'f'", "Python function")),
        Case("add_torque('t', body, lambda t: ...)", lambda: (lambda m, b, A: m.add_torque("t", b, lambda t: [0, 0, 1]))(*rod()),
             E.ModelError, ("torque 't'", "Python function")),
        Case("add_constraint('c', lambda: A.v[0])", lambda: (lambda m, b, A: m.add_constraint("c", lambda: A.v[0]))(*rod()),
             E.ModelError, ("constraint 'c'", "function")),
        Case("add_constraint(..., position=lambda q: q[0])", lambda: (lambda m, b, A: m.add_constraint(
            "c", A.v[0], position=lambda q: q[0]))(*rod()), E.ModelError, ("constraint 'c'", "position form")),
        Case("add_constraint('c', A.v[0] * A.v[1]) (not affine)", lambda: (lambda m, b, A: m.add_constraint(
            "c", A.v[0] * A.v[1]))(*rod()), E.NonAffineConstraintError, ("constraint 'c'", "rod.A.v")),
        Case("add_constraint('c', rod.q[0]) (no velocity)", lambda: (lambda m, b, A: m.add_constraint("c", b.q[0]))(*rod()),
             E.ModelError, ("constraint 'c'", "velocity")),
    ]),
    "redundant": ("redundant constraints: which can be dropped", _N + " (now says which to drop)", [
        Case("a revolute joint plus omega_x + omega_y = 0", redundant_with(lambda m, b, A: m.add_constraint(
            "extra", b.omega[0] + b.omega[1])), E.RedundantConstraintsError, ("Drop 'extra'", "'hinge.w1'", "'hinge.w2'")),
        Case("a revolute joint plus a copy of its E1 . v_A = 0", redundant_with(lambda m, b, A: m.add_constraint(
            "again", A.v[0], point=A)), E.RedundantConstraintsError, ("Drop 'again'", "or one of 'hinge.v1'")),
        Case("a revolute joint plus a ball-and-socket at the same point", redundant_with(
            lambda m, b, A: joints.ball_and_socket(m, "ball", A)), E.RedundantConstraintsError, ("Drop 'ball.v1', 'ball.v2', 'ball.v3'",)),
        Case("the same in an optimal-control problem (solve)", redundant_ocp, E.RedundantConstraintsError,
             ("Drop 'ball.v1', 'ball.v2', 'ball.v3'",)),
    ]),
    "cli_contract": ("the command line's contract: exit 2 and one line for bad input", _R, [
        Case("simulate a scene file whose build() divides by zero", scene_cli(
            "def build(p):\n    return 1 / 0\n"), 2, ("user_scene.py, line 5", "ZeroDivisionError", "mass=1")),
        Case("simulate a scene file whose build() reads a missing parameter", scene_cli(
            "def build(p):\n    m = Model('x')\n    return p['length']\n"), 2, ("line 6", "KeyError", "'length'")),
        Case("simulate a scene file whose build() returns None", scene_cli("def build(p):\n    return None\n"), 2,
             ("build() must return a Scene", "NoneType")),
        Case("simulate a scene file that fails on import", in_tmp(lambda tmp: cli("simulate", scene_file(
            tmp, "import no_such_module\ndef build(p):\n    pass\n"))), 2, ("user_scene.py", "line 4", "no_such_module")),
        Case("simulate a scene file with a syntax error", in_tmp(lambda tmp: cli("simulate", scene_file(
            tmp, "def build(p):\n    return (\n"))), 2, ("user_scene.py", "syntax")),
        Case("solve a scene file whose task raises", task_cli(
            "def build(p):\n    pass\ndef reach(p):\n    raise RuntimeError('no target')\nTASKS = {'reach': reach}\n"),
             2, ("task 'reach'", "line 7", "no target")),
        Case("gait --motion an empty .mat file", gait_with_mat(b""), 2, ("motion.mat", "not a readable MATLAB file")),
        Case("gait --motion a .mat file of text", gait_with_mat(b"not a mat file at all" * 8), 2, ("motion.mat",)),
        Case("gait --motion a .mat whose data are strings", gait_with_mat(
            {"s": {"data": np.array(["a", "b"]), "colheaders": np.array(["time", "x"], dtype=object)}}), 2,
             ("motion.mat", "'data' is not a numeric matrix")),
        Case("read_motion(a truncated .mat)", read_mat(b"MATLAB 5.0 MAT-file" + b"\0" * 200), E.DataFileError, ("motion.mat",)),
        Case("read_motion(a .mat without a data struct)", read_mat({"x": np.eye(3)}), E.DataFileError,
             ("motion.mat", "'data' and 'colheaders'")),
        Case("simulate no_such_scene", lambda: cli("simulate", "no_such_scene"), 2, ("unknown scene 'no_such_scene'", "whirling")),
        Case("simulate whirling --param nonsense=1", lambda: cli("simulate", "whirling", "--param", "nonsense=1"), 2,
             ("no parameter 'nonsense'", "omega")),
        Case("simulate whirling --param omega=fast", lambda: cli("simulate", "whirling", "--param", "omega=fast"), 2,
             ("'omega'", "number")),
        Case("simulate whirling --param omega", lambda: cli("simulate", "whirling", "--param", "omega"), 2, ("name=value",)),
        Case("simulate missing_dir/scene.py", lambda: cli("simulate", "missing_dir/scene.py"), 2, ("missing_dir/scene.py",)),
        Case("solve sliding_disk (a scene without tasks)", lambda: cli("solve", "sliding_disk"), 2, ("sliding_disk", "TASKS")),
        Case("solve pendulum --task nope", lambda: cli("solve", "pendulum", "--task", "nope"), 2, ("no task 'nope'", "swing_up")),
        Case("simulate pendulum --param mass=-1", lambda: cli("simulate", "pendulum", "--param", "mass=-1"), 2,
             ("body 'rod'", "mass must be positive")),
        Case("solve pendulum --ipopt no_such_option=1", lambda: cli("solve", "pendulum", "--intervals", "5", "--ipopt",
                                                                   "no_such_option=1"), 2,
             ("'ipopt.no_such_option' is not an IPOPT option",)),
        Case("solve pendulum --ipopt max_iter=-5", lambda: cli("solve", "pendulum", "--intervals", "5", "--ipopt",
                                                              "max_iter=-5"), 2, ("IPOPT refused a value", "'ipopt.max_iter': -5")),
    ]),
    "model_building": ("bodies and names", _N, [
        Case("add_body with a non-symmetric inertia", lambda: oc.Model("m").add_body("b", 1.0, [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]),
             E.ModelError, ("body 'b'", "symmetric")),
        Case("add_body with principal moments (1, 1, 3) (triangle inequality)", lambda: oc.Model("m").add_body(
            "b", 1.0, np.diag([1.0, 1.0, 3.0])), E.ModelError, ("body 'b'", "not physical")),
        Case("add_body with mass 0", lambda: oc.Model("m").add_body("b", 0.0, np.eye(3)), E.ModelError, ("body 'b'", "mass")),
        Case("add_body with rotation='xyz'", lambda: oc.Model("m").add_body("b", 1.0, np.eye(3), rotation="xyz"), E.ModelError,
             ("xyz",)),
        Case("add_body twice with one name", lambda: (lambda m: (m.add_body("b", 1.0, np.eye(3)), m.add_body("b", 1.0, np.eye(3))))(
            oc.Model("m")), E.ModelError, ("already has a body named 'b'",)),
        Case("add_constraint twice with one name", lambda: (lambda m, b, A: (m.add_constraint("c", A.v[0]), m.add_constraint(
            "c", A.v[1])))(*rod()), E.ModelError, ("already has a constraint named 'c'",)),
        Case("a start at the 3-1-3 singularity (theta = 0)", lambda: (lambda m, b, A: hanging_state(m))(*rod(rotation="313")),
             E.SingularConfigurationError, ("body 'rod'", "quaternion")),
        Case("simulate_scene(model): a model where a scene is expected", lambda: oc.simulate_scene(rod()[0], 0.1),
             E.SceneError, ("simulate_scene needs a Scene", "Model")),
    ]),
    "ocp_problem": ("an optimal-control problem written by a new user", _R, [
        Case("subject_to(psi, 2.0, 1.0): a path constraint's bounds reversed", with_rod_ocp(
            lambda p: p.subject_to(p.quantity("rod.psi"), 2.0, 1.0, "psi window")), E.ModelError,
             ("path constraint 'psi window'", "swap")),
        Case("subject_to(psi, nan, 1.0)", with_rod_ocp(
            lambda p: p.subject_to(p.quantity("rod.psi"), float("nan"), 1.0, "psi window")), E.ModelError,
             ("path constraint 'psi window'", "nan")),
        Case("minimize_effort(['motor'], weight=nan)", with_rod_ocp(
            lambda p: p.minimize_effort(["motor"], weight=float("nan"))), E.ModelError, ("'effort'", "finite")),
        Case("track('rod.psi', scipy's CubicSpline): a reference that is not a CasADi expression of t", with_rod_ocp(
            lambda p: p.track("rod.psi", __import__("scipy.interpolate").interpolate.CubicSpline([0, 1, 2], [0, 1, 0]))),
             E.ModelError, ("track('rod.psi', reference)", "ca.pw_lin", "it returned nan")),
        Case("initial({'rod.pssi': 0}): a misspelt quantity", with_rod_ocp(lambda p: p.initial({"rod.pssi": 0.0})),
             E.ModelError, ("'rod.pssi'", "did you mean 'rod.psi'")),
        Case("sol.sample('hinge@rod.F_x'): a joint load asked of sample()", lambda: (lambda p: (
            p.minimize_effort(["motor"]), p.solve(oc.Radau(5, degree=3)).sample("hinge@rod.F_x")))(rod_ocp()),
             E.ModelError, ("'hinge@rod.F_x'", ".loads()")),
        Case("a rod on the default 3-1-3 angles hinged about E3, only psi given at t0 (theta = 0: singular)",
             lambda: rod_ocp_313().solve(oc.Radau(5, degree=3)), E.ModelError, ("rod.phi", "'313' is singular", "quaternion")),
        Case("a quaternion body's orientations as qx, qy, qz only (was a silent wrong optimum)", quaternion_ball_ocp_three_components,
             unit_quaternion_turn),
    ]),
    "resources": ("a run larger than the machine", _S + " (grew without bound)", [
        Case("simulate(..., t_final=1e6)", lambda: simulate_scene_state("pendulum", t_final=1e6), E.ResourceLimitError,
             ("100,000,001 samples", "GB", "available", "dt >=")),
        Case("simulate whirling --t-final 1e6 into a folder of an earlier run", in_tmp(refused_run_keeps_folder), nothing_written),
        Case("SimulationOptions(max_memory=1e6) for 10 s at dt = 0.01", lambda: simulate_scene_state(
            "pendulum", t_final=10.0, options=oc.SimulationOptions(max_memory=1e6)), E.ResourceLimitError,
             ("1,001 samples", "MB", "limit 1 MB")),
        Case("the memory estimate itself", lambda: None, estimate_matches_tracemalloc),
    ]),
}


def _cases(key: str):
    return pytest.mark.parametrize("case", CATALOGUE[key][2], ids=[_id(c) for c in CATALOGUE[key][2]])


@_cases("state_off_constraints")
def test_state_off_the_constraints_is_refused_naming_the_constraints(case):
    outcome(case)


@_cases("time_grid")
def test_time_grid_ends_at_t_final_and_dt_is_checked(case):
    outcome(case)


@_cases("degree_without_radau")
def test_degree_without_radau_is_refused(case):
    outcome(case)


@_cases("rerun_into_out")
def test_rerun_replaces_the_previous_run_and_nothing_else(case):
    outcome(case)


@_cases("file_permissions")
def test_result_files_get_the_umask_permissions(case):
    outcome(case)


@_cases("non_finite")
def test_nan_or_inf_is_named_where_it_enters(case):
    outcome(case)


@_cases("singular_mass_matrix")
def test_singular_mass_matrix_names_body_and_axis(case):
    outcome(case)


@_cases("shape")
def test_wrong_length_or_shape_names_the_entries(case):
    outcome(case)


@_cases("foreign_point")
def test_point_or_body_of_another_model_is_refused(case):
    outcome(case)


@_cases("angle_index")
def test_euler_angle_index_is_checked(case):
    outcome(case)


@_cases("callable_for_expression")
def test_function_where_an_expression_is_expected_is_named(case):
    outcome(case)


@_cases("redundant")
def test_redundant_constraints_say_which_to_drop(case):
    outcome(case)


@_cases("cli_contract")
def test_command_line_exits_2_with_one_line_for_bad_input(case):
    outcome(case)


@_cases("model_building")
def test_model_building_errors_name_the_thing(case):
    outcome(case)


@_cases("ocp_problem")
def test_a_new_users_ocp_mistakes_are_refused_naming_the_thing(case):
    outcome(case)


@_cases("resources")
def test_runs_beyond_the_machine_are_refused_with_the_estimate(case):
    outcome(case)


def test_catalogue_has_at_least_60_cases():
    assert sum(len(c) for _, _, c in CATALOGUE.values()) >= 60
