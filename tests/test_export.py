"""C export (issue 4): round trip, the example program, only what a scene needs, bad input.

The compiled code is compared with the CasADi evaluation (round trip), and the exported
multipliers with independent values: the lambdas of forward simulations (KKT system,
CVODES), numpy's least squares of the inverse dynamics, and the sliding cylinder's
closed form ``lambda = (m g, -I_a psi' phi')`` (paper eq. 18) on states built by hand.
Every scene is exported and compiled once, in a module-scoped fixture.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import shutil
import subprocess

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.errors import OcpConstraintsError
from ocp_constraints.codegen.export import build_export, export_c, export_model_c, find_compiler, verify_export
from ocp_constraints.errors import CompilerError, CompilerNotFoundError, ExportError, RoundTripError
from ocp_constraints.cli.export import add_export_parser
from ocp_constraints.dynamics.inverse import InverseDynamics
from ocp_constraints.scenes.registry import build_scene, builtin_scene_names
from ocp_constraints.dynamics.simulate import SimulationOptions, simulate
from ocp_constraints.mechanics.state import consistent_state

SCENES = builtin_scene_names()

# A user's scene file: the whirling body with a time-varying drive Omega(t) and a brake
# torque about E1 as an actuator input (no built-in scene has inputs).
BRAKED_SCENE = '''
import math
import casadi as ca
import numpy as np
from ocp_constraints import joints
from ocp_constraints.mechanics.model import Model
from ocp_constraints.mechanics.rotations import EulerSequence
from ocp_constraints.scenes.registry import Scene

DESCRIPTION = "whirling body, drive Omega(t) = 2 + 0.5 sin t, brake torque input about E1"
DEFAULTS = {"brake": 0.3}


def build(p):
    model = Model("braked_whirl", gravity=(0.0, 0.0, -9.81), parameters=p)
    J = [[0.040, 0.003, 0.006], [0.003, 0.020, -0.005], [0.006, -0.005, 0.050]]
    body = model.add_body("body", 1.2, J, rotation="313")
    com = np.array([0.08, -0.45, 0.06])
    joints.ball_and_socket(model, "shaft", body.point("A", -com))
    joints.driven_axis(model, "shaft", body, 2.0 + 0.5 * ca.sin(model.t), index=1)
    brake = model.add_input("brake")
    model.add_torque("brake", body, ca.vertcat(brake, 0, 0))
    theta = math.pi / 2 + 0.5
    x = np.asarray(EulerSequence("313").rotation([0.0, theta, 0.0])) @ com
    coords = {"body.x": x[0], "body.y": x[1], "body.z": x[2], "body.psi": 0.0, "body.theta": theta, "body.phi": 0.0}
    return Scene(model, coords, {"body.theta_dot": 0.0, "body.phi_dot": 0.3}, t_final=1.0,
                 inputs=lambda t: [p["brake"] * math.cos(t)])
'''


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Every built-in scene exported with the round trip, and its library built once more."""
    root = tmp_path_factory.mktemp("export")
    cc = find_compiler()
    out = {}
    for name in SCENES:
        report = export_c(name, root / name, verify=True)
        build = root / f"{name}-build"
        build.mkdir()
        lib, _, _ = build_export(report.out_dir, report.prefix, build, cc)
        out[name] = (report, lib)
    return out


def c_eval(report, lib, suffix: str, **blocks) -> dict[str, np.ndarray]:
    """Evaluate the compiled ``<prefix>_<suffix>`` (casadi.external) on rows of ``blocks``."""
    fn = report.function(suffix)
    ext = ca.external(fn.casadi_name, str(lib))
    args = [np.atleast_2d(np.asarray(blocks[b], float)) for b in fn.inputs]
    n = args[0].shape[0]
    res = ext.map(n)(*[a.reshape(n, -1).T for a in args])
    res = res if isinstance(res, (list, tuple)) else [res]
    return {b: np.asarray(r).reshape(-1, n).T for b, r in zip(fn.outputs, res)}


def parse_printout(text: str) -> dict[tuple[str, str], np.ndarray]:
    rows: dict[tuple[str, str], dict[int, float]] = {}
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        fn, block, index, _, value = line.split()
        rows.setdefault((fn, block), {})[int(index)] = float(value)
    return {k: np.array([v[i] for i in range(len(v))]) for k, v in rows.items()}


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


# -- round trip --------------------------------------------------------------------------
@pytest.mark.parametrize("scene", SCENES)
def test_round_trip_agrees_to_1e_12_on_1000_random_states(exported, scene):
    report, _ = exported[scene]
    rt = report.round_trip
    assert rt.n_states == 1000
    names = [f.name for f in report.functions]
    assert set(rt.casadi_external) == set(rt.c_api) == set(names)
    assert set(rt.example) == {f"{f.name}.{b}" for f in report.functions for b in f.outputs}
    assert rt.max_error <= 1e-12, rt.to_dict()
    assert rt.compiler_output == ""  # no warning under -Wall -Wextra -Werror -O2
    # the folder holds the sources, not the build
    files = sorted(p.name for p in report.out_dir.iterdir())
    p = report.prefix
    assert files == sorted(["CMakeLists.txt", "Makefile", "export.json", f"{p}_casadi.c", f"{p}_casadi.h",
                            f"{p}_constraints.c", f"{p}_constraints.h", f"{p}_example.c"])
    assert report.code_bytes > 0 and report.code_lines > 0
    for f in report.functions:
        assert 0 < f.code_bytes and 0 < f.code_lines and f.n_operations <= f.n_instructions


def test_verify_export_on_the_final_folder_leaves_it_untouched(exported):
    report, _ = exported["whirling"]
    before = {p.name: p.stat().st_mtime_ns for p in report.out_dir.iterdir()}
    rt = verify_export(report, n_states=1000, seed=7)
    assert rt.passed and rt.seed == 7
    assert {p.name: p.stat().st_mtime_ns for p in report.out_dir.iterdir()} == before


def test_round_trip_catches_a_wrong_constant(exported, tmp_path):
    report, _ = exported["whirling"]
    bad = tmp_path / "bad"
    shutil.copytree(report.out_dir, bad)
    code = bad / "whirling_casadi.c"
    text = code.read_text()
    assert text.count("=1.2000000000000000e+00;") >= 1  # the mass
    code.write_text(text.replace("=1.2000000000000000e+00;", "=1.2000001000000000e+00;"))
    with pytest.raises(RoundTripError, match=r"disagrees with CasADi beyond 1e-12.*whirling_multipliers"):
        verify_export(dataclasses.replace(report, out_dir=bad), n_states=100)


def test_export_model_c_from_equations_with_a_random_sample(tmp_path):
    eqs = SystemEquations(build_scene("pendulum").model)
    report = export_model_c(eqs, tmp_path / "p", "my pendulum", verify=True, n_states=200)
    assert report.prefix == "my_pendulum" and (tmp_path / "p" / "my_pendulum_constraints.h").is_file()
    assert report.round_trip.max_error <= 1e-12 and report.round_trip.n_states == 200
    assert set(report.sample) == {"q", "u", "udot", "t"}


@pytest.mark.parametrize("scene", ["whirling", "ball_socket"])
def test_makefile_builds_without_warnings_and_example_printout_matches(exported, scene, tmp_path):
    report, _ = exported[scene]
    work = tmp_path / scene
    shutil.copytree(report.out_dir, work)
    cc = " ".join(find_compiler())
    proc = subprocess.run(["make", f"CC={cc}"], cwd=work, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in (proc.stdout + proc.stderr).lower()
    assert "-Wall -Wextra -Werror -O2" in proc.stdout
    run = subprocess.run([str(work / report.example_name)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    out = parse_printout(run.stdout)
    p = report.prefix
    # exactly what CasADi gives at the embedded sample (loads at the printed multipliers)
    sample = dict(report.sample, lam=out[(f"{p}_multipliers", "lam")])
    for fn in report.functions:
        ref = fn.function(*[sample[b] for b in fn.inputs])
        ref = ref if isinstance(ref, (list, tuple)) else [ref]
        for b, r in zip(fn.outputs, ref):
            assert out[(fn.name, b)].shape == (report.blocks[b].size,)
            assert np.allclose(out[(fn.name, b)], np.asarray(r).ravel(), rtol=1e-12, atol=1e-300), (fn.name, b)
    # and the physics: the sample is the consistent initial state, lambda that of the forward dynamics
    scene_obj = build_scene(scene)
    eqs = SystemEquations(scene_obj.model)
    q0, u0 = consistent_state(eqs, scene_obj.coordinates, scene_obj.rates)
    traj = simulate(eqs, q0, u0, 0.01)
    assert np.allclose(report.sample["q"], q0, rtol=0, atol=0) and np.allclose(report.sample["u"], u0, rtol=0, atol=0)
    assert rel(out[(f"{p}_multipliers", "lam")], traj.lam[0]) <= 1e-9
    assert np.abs(out[(f"{p}_residual", "pi")]).max() <= 1e-12


def test_cmake_builds_the_library_and_the_example(exported, tmp_path):
    report, _ = exported["sliding_cylinder"]
    src = tmp_path / "src"
    shutil.copytree(report.out_dir, src)
    env = {**os.environ, "CC": find_compiler()[0]}
    for cmd in (["cmake", "-S", str(src), "-B", str(tmp_path / "build")], ["cmake", "--build", str(tmp_path / "build")]):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert "warning:" not in proc.stdout + proc.stderr
    run = subprocess.run([str(tmp_path / "build" / report.example_name)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and len(parse_printout(run.stdout)) == 9


# -- only what the scene needs -----------------------------------------------------------
def test_no_moment_code_for_pure_force_joints_and_moment_code_where_needed(exported):
    for scene, has_moment in (("rolling_disk", False), ("sliding_disk", False), ("ball_socket", False),
                              ("whirling", True), ("pendulum", True), ("sliding_cylinder", True)):
        report, _ = exported[scene]
        p = report.prefix
        outputs = {b for f in report.functions for b in f.outputs}
        header = (report.out_dir / f"{p}_constraints.h").read_text()
        code = (report.out_dir / f"{p}_casadi.c").read_text()
        assert (("h" in outputs) and ("moment" in outputs)) is has_moment, scene
        assert (f"{p.upper()}_MOMENT_SIZE" in header) is has_moment
        assert ('"moment"' in code) is has_moment and ('"h"' in code) is has_moment
    # structural zeros: constant unit-vector gradients and e = 0 cost no arithmetic at all
    for scene in ("rolling_disk", "sliding_disk", "ball_socket"):
        assert exported[scene][0].function("gradients").n_operations == 0


def test_builtin_scenes_have_no_inputs_or_time_argument(exported):
    for scene, (report, _) in exported.items():
        header = (report.out_dir / f"{report.prefix}_constraints.h").read_text()
        for f in report.functions:
            assert "inputs" not in f.inputs and "t" not in f.inputs, (scene, f.name, f.inputs)
            assert [f.function.name_in(k) for k in range(f.function.n_in())] == f.inputs
        assert "const double inputs[" not in header and "double t," not in header and "double t)" not in header


def test_user_scene_gets_time_and_inputs_only_where_used(tmp_path):
    path = tmp_path / "braked_whirl.py"
    path.write_text(BRAKED_SCENE)
    report = export_c(str(path), tmp_path / "out", verify=True)
    assert report.round_trip.max_error <= 1e-12
    args = {f.name.split("_")[-1]: f.inputs for f in report.functions}
    assert args == {"residual": ["q", "u", "t"], "gradients": ["q", "t"], "loads": ["q", "u", "lam"],
                    "multipliers": ["q", "u", "udot", "inputs"]}  # G and f do not depend on t here
    header = (report.out_dir / "braked_whirl_constraints.h").read_text()
    assert "const double udot[BRAKED_WHIRL_UDOT_SIZE], const double inputs[BRAKED_WHIRL_INPUTS_SIZE], double lam[" in header
    assert "const double u[BRAKED_WHIRL_U_SIZE], double t, double pi[" in header
    assert "#define BRAKED_WHIRL_INPUTS_BRAKE" in header
    # multipliers with a time-varying drive and a brake input, against a simulation
    scene = build_scene(str(path))
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 1.0, SimulationOptions(dt=0.05), inputs=scene.inputs)
    lib_dir = tmp_path / "build"
    lib_dir.mkdir()
    lib, _, _ = build_export(report.out_dir, report.prefix, lib_dir, find_compiler())
    w = np.array([scene.inputs(t) for t in traj.t])
    lam = c_eval(report, lib, "multipliers", q=traj.q, u=traj.u, udot=traj.udot, t=traj.t, inputs=w)["lam"]
    assert rel(lam, traj.lam) <= 1e-8
    # the brake matters: without it the multipliers differ
    lam0 = c_eval(report, lib, "multipliers", q=traj.q, u=traj.u, udot=traj.udot, t=traj.t, inputs=0 * w)["lam"]
    assert rel(lam0, traj.lam) > 1e-3


@pytest.mark.parametrize("scene", SCENES)
def test_header_names_every_argument_entry_in_order(exported, scene):
    report, _ = exported[scene]
    eqs = report.eqs
    header = (report.out_dir / f"{report.prefix}_constraints.h").read_text()
    P = report.prefix.upper()

    def documented(block: str) -> list[str]:
        found = re.findall(rf"#define {P}_{block.upper()}_\w+\s+(\d+)\s+/\* (\S+) \[", header)
        assert [int(i) for i, _ in found] == list(range(len(found)))
        return [n for _, n in found]

    assert documented("q") == eqs.model.coordinate_names
    assert documented("u") == eqs.model.speed_names
    assert documented("lam") == [f"{c}.lambda" for c in eqs.constraint_names]
    assert documented("pi") == [f"{c}.pi" for c in eqs.constraint_names]
    assert documented("power") == [f"{ch.prefix}.power" for ch in eqs.load_channels]
    assert documented("force") == [f"{ch.prefix}.F_{a}" for ch in eqs.load_channels for a in "xyz"]
    assert f"#define {P}_Q_SIZE {eqs.nq}" in header and f"#define {P}_LAM_SIZE {eqs.nc}" in header
    for unit in ("[m]", "[m/s]", "[rad/s]", "[N]", "[W]"):
        assert unit in header
    assert "fixed right-handed basis E1, E2, E3" in header
    # the layout in the header is the layout the CasADi functions use
    for f in report.functions:
        for k, b in enumerate(f.inputs):
            assert f.function.size1_in(k) == (1 if b == "t" else report.blocks[b].size)


# -- the multipliers against independent values ------------------------------------------------
@pytest.mark.parametrize("scene", SCENES)
def test_multipliers_equal_the_lambdas_of_a_forward_simulation(exported, scene):
    report, lib = exported[scene]
    s = build_scene(scene)
    eqs = SystemEquations(s.model)
    q0, u0 = consistent_state(eqs, s.coordinates, s.rates)
    traj = simulate(eqs, q0, u0, 1.0, SimulationOptions(dt=0.05))
    lam = c_eval(report, lib, "multipliers", q=traj.q, u=traj.u, udot=traj.udot)["lam"]
    assert rel(lam, traj.lam) <= 1e-8


def test_multipliers_with_time_varying_drive_match_simulation(physics_whirling_varying_3s, tmp_path):
    _, eqs, traj = physics_whirling_varying_3s
    report = export_c("whirling", tmp_path / "w", {"omega_amplitude": 0.5})
    # Omega(t) enters e only: the residual and gradients take t, the multipliers do not
    assert report.function("residual").inputs == ["q", "u", "t"] and report.function("gradients").inputs == ["q", "t"]
    assert report.function("multipliers").inputs == ["q", "u", "udot"]
    lib, _, _ = build_export(report.out_dir, report.prefix, tmp_path, find_compiler())
    lam = c_eval(report, lib, "multipliers", q=traj.q, u=traj.u, udot=traj.udot, t=traj.t)["lam"]
    assert rel(lam, traj.lam) <= 1e-8
    drive = eqs.constraint_names.index("shaft.drive")
    assert np.ptp(lam[:, drive]) > 0.01  # the motor torque does vary


def test_multipliers_equal_numpy_least_squares_on_random_states(exported):
    report, lib = exported["whirling"]
    rng = np.random.default_rng(3)
    n = 50
    q = np.column_stack([rng.standard_normal((n, 3)), rng.uniform(-3, 3, n), rng.uniform(0.4, 2.7, n), rng.uniform(-3, 3, n)])
    u, udot = rng.standard_normal((n, 6)), rng.standard_normal((n, 6))
    lam = c_eval(report, lib, "multipliers", q=q, u=u, udot=udot)["lam"]
    expected = InverseDynamics(report.eqs).solve(np.zeros(n), q, u, udot).lam
    assert rel(lam, expected) <= 1e-10


def test_sliding_cylinder_multipliers_match_closed_form_eq18(exported):
    """On the plane (theta = pi/2, z = 0) with ``omega = psi' E3 + phi' e3``, the motion has
    ``vbar' = 0`` and ``omega' = psi' phi' E3 x e3``; then ``lambda = (m g, -I_a psi' phi')``."""
    report, lib = exported["sliding_cylinder"]
    p = report.parameters
    m, g, Ia = p["mass"], p["gravity"], p["mass"] * p["radius"] ** 2 / 2
    rng = np.random.default_rng(5)
    n = 40
    x, y, psi, phi = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-3, 3, n), rng.uniform(-3, 3, n)
    xd, yd, psid, phid = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-3, 3, n), rng.uniform(-8, 8, n)
    e3 = np.column_stack([np.sin(psi), -np.cos(psi), np.zeros(n)])  # R3(psi) R1(pi/2) R3(phi) E3
    E3 = np.array([0.0, 0.0, 1.0])
    omega = psid[:, None] * E3 + phid[:, None] * e3
    q = np.column_stack([x, y, np.zeros(n), psi, np.full(n, math.pi / 2), phi])
    u = np.column_stack([xd, yd, np.zeros(n), omega])
    udot = np.column_stack([np.zeros((n, 3)), (psid * phid)[:, None] * np.cross(E3, e3)])
    out = c_eval(report, lib, "multipliers", q=q, u=u, udot=udot)["lam"]
    expected = np.column_stack([np.full(n, m * g), -Ia * psid * phid])
    assert np.abs(out - expected).max() <= 1e-12 * np.abs(expected).max()


@pytest.mark.parametrize("scene", SCENES)
def test_loads_are_the_prescription_of_the_gradients(exported, scene):
    """Across three compiled functions: per joint, ``F_c = sum lambda_k f_k`` and its power
    ``sum_channels (F . v_C + M . omega) = sum_k lambda_k (pi_k - e_k)`` (eq. 27 off the manifold)."""
    report, lib = exported[scene]
    eqs = report.eqs
    rng = np.random.default_rng(11)
    n = 30
    s = report.sample
    q = s["q"] + 0.2 * rng.standard_normal((n, eqs.nq))
    u, lam = rng.standard_normal((n, eqs.nu)), rng.standard_normal((n, eqs.nc))
    pi = c_eval(report, lib, "residual", q=q, u=u)["pi"]
    grads = c_eval(report, lib, "gradients", q=q)
    loads = c_eval(report, lib, "loads", q=q, u=u, lam=lam)
    f_names = [e.name for e in report.blocks["f"].entries] if "f" in report.blocks else []
    for j, joint in eqs.model.joints.items():
        ks = [eqs.constraint_names.index(c.name) for c in joint.constraints]
        chans = [i for i, ch in enumerate(eqs.load_channels) if ch.joint == j]
        power = loads["power"][:, chans].sum(axis=1)
        expected = sum(lam[:, k] * (pi[:, k] - grads["e"][:, k]) for k in ks)
        assert np.abs(power - expected).max() <= 1e-12 * max(1.0, np.abs(expected).max())
        for i in chans:
            ch = eqs.load_channels[i]
            F = np.zeros((n, 3))
            for k in ks:
                c = eqs.constraints[k]
                label = c.name if len(c.shares) == 1 else f"{c.name}@{ch.body}"
                if f"{label}.f_x" in f_names:
                    col = f_names.index(f"{label}.f_x")
                    F += lam[:, [k]] * grads["f"][:, col:col + 3]
            assert np.abs(loads["force"][:, 3 * i:3 * i + 3] - F).max() <= 1e-12 * max(1.0, np.abs(F).max())


# -- bad input -----------------------------------------------------------------------------
def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_unwritable_output_folder_is_a_clear_error(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    with pytest.raises(ExportError, match=r"cannot write the export to '.*a_file/out'.*"):
        export_c("sliding_disk", blocker / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]
    with pytest.raises(ExportError, match="exists and is not a folder"):
        export_c("sliding_disk", blocker)


def test_existing_folder_that_is_not_an_export_is_left_alone(tmp_path):
    target = tmp_path / "mine"
    target.mkdir()
    (target / "notes.txt").write_text("keep me")
    with pytest.raises(ExportError, match="not an earlier export"):
        export_c("sliding_disk", target)
    assert [p.name for p in target.iterdir()] == ["notes.txt"] and _leftovers(tmp_path) == []


def test_missing_compiler_names_it_and_leaves_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.raises(CompilerNotFoundError, match=r"no-such-cc.*\$CC.*not found"):
        export_c("rolling_disk", tmp_path / "out", verify=True)
    assert list(tmp_path.iterdir()) == []
    assert isinstance(CompilerNotFoundError("x"), OcpConstraintsError)


def test_failing_compiler_shows_its_own_message_and_keeps_the_earlier_export(tmp_path, monkeypatch):
    out = tmp_path / "out"
    first = export_c("rolling_disk", out)  # an earlier, good export (not compiled)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    fake = tmp_path / "fake-cc"
    fake.write_text("#!/bin/sh\necho 'fake-cc: licence server unreachable' >&2\nexit 3\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    with pytest.raises(CompilerError, match=r"(?s)exit status 3.*fake-cc: licence server unreachable"):
        export_c("rolling_disk", out, verify=True)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert _leftovers(tmp_path) == [] and first.round_trip is None


def test_real_compiler_error_is_reported_verbatim(exported, monkeypatch):
    report, _ = exported["sliding_disk"]
    monkeypatch.setenv("CC", f"{find_compiler()[0]} -include no_such_header_4711.h")
    with pytest.raises(CompilerError, match=r"(?s)failed building.*no_such_header_4711\.h"):
        verify_export(report, n_states=10)


def test_failure_while_writing_leaves_no_half_written_folder(tmp_path, monkeypatch):
    import ocp_constraints.codegen.export as export

    def broken(_report):
        raise RuntimeError("disk full (simulated)")

    monkeypatch.setattr(export, "_example", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        export_c("sliding_disk", tmp_path / "out")
    assert list(tmp_path.iterdir()) == []


# -- command line ------------------------------------------------------------------------------
def _parser():
    parser = argparse.ArgumentParser(prog="ocp-constraints")
    add_export_parser(parser.add_subparsers(dest="command", required=True))
    return parser


def test_cli_export_c_writes_verified_export(tmp_path, capsys):
    args = _parser().parse_args(["export-c", "sliding_disk", "--out", str(tmp_path / "sd"), "--param", "mass=2.5"])
    assert args.handler(args) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith("sliding_disk: 4 functions") and "max relative error" in line and "\n" not in line
    header = (tmp_path / "sd" / "sliding_disk_constraints.h").read_text()
    assert "mass = 2.5" in header
    args = _parser().parse_args(["export-c", "sliding_disk", "--out", str(tmp_path / "sd"), "--no-verify"])
    assert args.handler(args) == 0 and "not compiled" in capsys.readouterr().out
    args = _parser().parse_args(["export-c", "sliding_disk", "--out", str(tmp_path / "x"), "--param", "mass=heavy"])
    with pytest.raises(OcpConstraintsError, match="mass"):
        args.handler(args)
    args = _parser().parse_args(["export-c", "no_such_scene", "--out", str(tmp_path / "y")])
    with pytest.raises(OcpConstraintsError, match="unknown scene"):
        args.handler(args)
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_cli_bench_export_reports_and_writes_markdown(tmp_path, capsys):
    md = tmp_path / "bench.md"
    args = _parser().parse_args(["bench-export", "sliding_disk", "--runs", "1", "--markdown", str(md)])
    assert args.handler(args) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith("multipliers evaluations per second") and "sliding_disk" in line
    table = md.read_text()
    assert table.count("| sliding_disk |") == 3 and "C loop" in table and "map" in table
    rates = [float(r.split("|")[3]) for r in table.splitlines() if r.startswith("| sliding_disk")]
    assert all(r > 0 for r in rates)
    with pytest.raises(SystemExit):
        _parser().parse_args(["bench-export", "--runs", "0"])
