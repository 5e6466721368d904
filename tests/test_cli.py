"""The ``ocp-constraints`` command: results files as DESIGN.md specifies, and bad input."""
from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess

import pytest

from ocp_constraints.cli.main import main


def read_header(path):
    with open(path) as fh:
        return next(csv.reader(fh))


def test_installed_command_writes_results_files_for_whirling(tmp_path):
    exe = shutil.which("ocp-constraints")
    assert exe, "the console script is not installed (pip install -e .)"
    out = tmp_path / "whirling"
    proc = subprocess.run([exe, "simulate", "whirling", "--out", str(out)], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert proc.returncode == 0, proc.stderr
    for name in ("summary.json", "trajectory.csv", "loads.csv", "coordinates.png", "loads_shaft.png", "energy.png"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scene"] == "whirling" and summary["task"] == "simulate" and summary["success"] is True
    assert summary["parameters"]["omega"] == 2.0
    assert summary["max_constraint_residual"]["position"] <= 1e-9
    assert {"casadi", "numpy", "python", "ocp_constraints"} <= set(summary["software"])
    traj = read_header(out / "trajectory.csv")
    assert traj[0] == "t"
    for col in ("body.x", "body.psi", "body.theta", "body.phi", "body.theta_dot", "body.omega_x", "body.vbar_z"):
        assert col in traj
    loads = read_header(out / "loads.csv")
    for col in ("shaft.v1.lambda", "shaft.drive.lambda", "shaft.lock.lambda", "shaft.F_x", "shaft.F_z",
                "shaft.M_x", "shaft.M_z", "shaft.point_x", "shaft.point_z", "shaft.power"):
        assert col in loads
    rows = list(csv.reader(open(out / "loads.csv")))
    assert len(rows) == 1002  # header + t = 0, 0.01, ..., 10
    assert not list(out.glob(".*tmp"))  # no temporary files left behind


def test_two_body_joint_reports_load_on_each_body(tmp_path):
    assert main(["simulate", "ball_socket", "--t-final", "0.2", "--out", str(tmp_path), "--no-plots"]) == 0
    loads = read_header(tmp_path / "loads.csv")
    assert "socket_C@body1.F_x" in loads and "socket_C@body2.F_x" in loads and "socket_O.F_x" in loads
    rows = list(csv.DictReader(open(tmp_path / "loads.csv")))
    for r in rows:
        for axis in "xyz":  # Newton's third law from the prescription (sec. 6)
            assert float(r[f"socket_C@body1.F_{axis}"]) == pytest.approx(-float(r[f"socket_C@body2.F_{axis}"]), abs=1e-12)
    assert not list(tmp_path.glob("*.png"))


def test_list_shows_every_builtin_scene(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("pendulum", "sliding_cylinder", "sliding_disk", "rolling_disk", "whirling", "ball_socket"):
        assert name in out


def test_param_override_reaches_the_model(tmp_path):
    assert main(["simulate", "pendulum", "--t-final", "0.1", "--param", "mass=2.5", "--out", str(tmp_path), "--no-plots"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["parameters"]["mass"] == 2.5


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["simulate", "no_such_scene"], ["unknown scene 'no_such_scene'", "whirling"]),
        (["simulate", "whirling", "--param", "nonsense=1"], ["no parameter 'nonsense'", "omega"]),
        (["simulate", "whirling", "--param", "omega=nan"], ["'omega'", "finite"]),
        (["simulate", "whirling", "--param", "omega=inf"], ["'omega'", "finite"]),
        (["simulate", "whirling", "--param", "omega=fast"], ["'omega'", "number"]),
        (["simulate", "whirling", "--param", "omega"], ["name=value"]),
        (["simulate", "missing_dir/scene.py"], ["missing_dir/scene.py", "does not exist"]),
    ],
)
def test_bad_input_exits_2_with_a_message_naming_the_culprit(argv, expected, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    for text in expected:
        assert text in err


def test_broken_scene_file_is_reported_with_file_and_line(tmp_path, capsys):
    bad = tmp_path / "broken.py"
    bad.write_text("DEFAULTS = {}\n\ndef build(p):\n    return (\n")
    assert main(["simulate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "broken.py" in err and "line" in err and "syntax" in err


def test_scene_file_without_build_is_reported(tmp_path, capsys):
    bad = tmp_path / "empty_scene.py"
    bad.write_text("DEFAULTS = {}\n")
    assert main(["simulate", str(bad)]) == 2
    assert "does not define build" in capsys.readouterr().err


USER_SCENE = '''
"""A user's own scene: a point mass on a string (spherical pendulum)."""
import casadi as ca
from ocp_constraints import joints
from ocp_constraints.mechanics.model import Model
from ocp_constraints.scenes.registry import Scene

DESCRIPTION = "spherical pendulum"
DEFAULTS = {"length": 0.7, "mass": 0.3}

def build(p):
    model = Model("spherical", parameters=p)
    bob = model.add_body("bob", p["mass"], [[1e-4, 0, 0], [0, 1e-4, 0], [0, 0, 1e-4]], rotation="quaternion")
    pivot = bob.point("pivot", [0, 0, p["length"]])
    joints.ball_and_socket(model, "string", pivot)
    coords = {"bob.x": 0.0, "bob.y": 0.0, "bob.z": -p["length"], "bob.qw": 1.0, "bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0}
    return Scene(model, coords, {"bob.omega_x": 1.0, "bob.omega_y": 0.5, "bob.omega_z": 0.0}, t_final=1.0)
'''


def test_user_scene_file_runs_like_a_builtin(tmp_path):
    path = tmp_path / "my_scene.py"
    path.write_text(USER_SCENE)
    out = tmp_path / "out"
    assert main(["simulate", str(path), "--param", "length=0.5", "--out", str(out), "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["length"] == 0.5
    rows = list(csv.DictReader(open(out / "loads.csv")))
    # At the start the bob hangs with angular velocity (1, 0.5, 0) about its pivot:
    # tension = m g + m |omega|^2 L (centripetal), a closed form.
    w2 = 1.0**2 + 0.5**2
    assert float(rows[0]["string.F_z"]) == pytest.approx(0.3 * 9.81 + 0.3 * w2 * 0.5, rel=1e-9)


def test_unwritable_output_folder_is_a_clear_error(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["simulate", "whirling", "--t-final", "0.1", "--out", str(blocker / "sub")]) == 2
    assert "cannot write results" in capsys.readouterr().err


@pytest.mark.parametrize("command", [["simulate", "whirling", "--t-final", "0.5"],
                                     ["gait", "--model", "{G}/subject01_simbody.osim", "--motion",
                                      "{G}/subject01_walk1_ik.mot", "--grf", "{G}/subject01_walk1_grf.mot"]])
def test_a_disk_that_fills_while_the_results_are_written_is_one_line_and_keeps_the_folder(tmp_path, command):
    """The results outgrow what the file system lets the run write (a real limit: RLIMIT_FSIZE, what a full
    disk or a quota does to a write, EFBIG for ENOSPC): exit 2, one line naming the folder, no traceback, and
    the folder keeps what it held (it was a traceback, with a staging folder left behind)."""
    import resource
    import signal
    from pathlib import Path

    shared = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim-gait2354-subject01"
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("the user's own file")

    def small_files():      # in the child: 8 kB per file, and the write fails instead of killing the process
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192))

    args = [a.format(G=shared) for a in command]
    proc = subprocess.run([shutil.which("ocp-constraints"), *args, "--no-plots", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, preexec_fn=small_files,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == f"error: cannot write results to '{out}': File too large"
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt"]


def test_failed_simulation_writes_partial_results_marked_unsuccessful(tmp_path):
    code = main(["simulate", "sliding_disk", "--t-final", "2", "--out", str(tmp_path), "--no-plots",
                 "--param", "theta0=0.3", "--param", "psi_dot0=0", "--param", "phi_dot0=0",
                 "--param", "theta_dot0=-2", "--param", "x_dot0=0", "--param", "y_dot0=0"])
    assert code == 1
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success"] is False and "singular" in summary["message"]
    assert summary["t_reached"] < 2.0
    assert math.isfinite(summary["max_constraint_residual"]["velocity"])


def test_solve_hands_ipopt_options_to_every_solve_and_records_them(tmp_path, capsys):
    """--ipopt NAME=VALUE reaches IPOPT (two iterations allowed: it stops there, exit 1, the status named with
    the option that set the limit) and summary.json records it as the option given (an integer stays an integer)."""
    code = main(["solve", "pendulum", "--intervals", "10", "--ipopt", "max_iter=2", "--out", str(tmp_path), "--no-plots"])
    assert code == 1
    err = capsys.readouterr().err
    assert "Maximum_Iterations_Exceeded" in err and "'ipopt.max_iter' = 2" in err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["solver"]["ipopt_options"] == {"ipopt.max_iter": 2} and summary["iterations"] == 2
    assert summary["success"] is False


@pytest.mark.parametrize("given, named", [("max_iter", "NAME=VALUE"), ("no_such_option=1", "'ipopt.no_such_option'"),
                                          ("max_iter=-5", "'ipopt.max_iter': -5"), ("tol=abc", "'ipopt.tol': 'abc'")])
def test_solve_refuses_a_malformed_or_unknown_ipopt_option_naming_it(given, named, capsys):
    """Bad input, exit 2 and one line naming the option (CasADi refuses unknown names and IPOPT bad values when
    the solver is made: a raw RuntimeError before)."""
    assert main(["solve", "pendulum", "--intervals", "10", "--ipopt", given]) == 2
    err = capsys.readouterr().err
    assert named in err and "Traceback" not in err


def test_an_option_that_is_not_nlpsols_is_refused_by_name_in_the_api():
    import ocp_constraints as oc
    from ocp_constraints.errors import ModelError
    from ocp_constraints.scenes.registry import build_task

    problem = build_task("pendulum", None)[1]
    with pytest.raises(ModelError, match="'foo' is not an option of CasADi's nlpsol.*'ipopt.foo'"):
        problem.solve(oc.Radau(5), {"foo": 1})


def test_solve_to_a_tolerance_counts_every_solves_iterations_and_takes_max_refinements(tmp_path, capsys):
    """Under --tolerance the line and summary.json said "3 iterations", the last solve's, where the refinement
    took 17 over 3 solves; the refinement message's advice, --max-refinements, was no option."""
    out = tmp_path / "swing_up"
    assert main(["solve", "pendulum", "--tolerance", "1e-6", "--max-refinements", "3", "--no-plots",
                 "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    history = s["mesh_refinement"]["history"]
    assert s["iterations"] == sum(h["iterations"] + h.get("companion_iterations", 0) for h in history)
    assert s["iterations"] > s["iterations_last_solve"] and s["solves"] == sum(h["solves"] for h in history)
    assert f"(the last of {s['solves']} solves, {s['iterations']} iterations in all)" in capsys.readouterr().out
    assert main(["solve", "pendulum", "--max-refinements", "3", "--out", str(tmp_path / "x")]) == 2
    assert "--max-refinements 3 applies with --tolerance only" in capsys.readouterr().err


def test_gait_and_knee_refuse_an_unwritable_out_before_computing(tmp_path, capsys, monkeypatch):
    """The folder is checked first: it was checked when the results were written, after the whole inverse dynamics
    and optimisation (7 s of knee lost)."""
    from pathlib import Path

    import ocp_constraints.biomech.gait as gait
    import ocp_constraints.biomech.knee_pipeline as knee

    def computed(*args, **kwargs):
        raise AssertionError("computed before --out was checked")

    monkeypatch.setattr(gait, "run_inverse_dynamics", computed)
    monkeypatch.setattr(knee, "run_knee", computed)
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    g = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim-gait2354-subject01"
    data = ["--model", str(g / "subject01_simbody.osim"), "--motion", str(g / "subject01_walk1_ik.mot"),
            "--grf", str(g / "subject01_walk1_grf.mot"), "--no-plots", "--out", str(blocker / "sub")]
    for command in ("gait", "knee"):
        assert main([command, *data]) == 2
        assert "cannot write results" in capsys.readouterr().err
