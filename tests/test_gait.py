"""Inverse dynamics of real gait trials against OpenSim's own inverse dynamics.

gait2354 has two OpenSim references: the ``inverse_dynamics.sto`` shipped with the example
(made by an older OpenSim) and ``tests/data/gait2354_subject01_id_opensim46.sto`` made by
OpenSim 4.6 from exactly our inputs (see tests/data/README.md). We reproduce the second
to 0.01 N m; the first differs from OpenSim 4.6 itself by 3.1 % of peak at the right knee.
"""
import importlib.util
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.errors import OcpConstraintsError
from ocp_constraints.biomech.gait import compare, run_inverse_dynamics
from ocp_constraints.errors import GaitError
from ocp_constraints.cli.gait import add_gait_parser
from ocp_constraints.cli.gait import cli_gait
from ocp_constraints.biomech.opensim_files import read_forces, read_grf
from ocp_constraints.errors import DataFileError

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
G = DATA / "opensim-gait2354-subject01"
J = DATA / "grand-challenge-knee-jw"
JW_MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
OPENSIM46 = Path(__file__).resolve().parent / "data" / "gait2354_subject01_id_opensim46.sto"
FLEXION_R = ["hip_flexion_r", "knee_angle_r", "ankle_angle_r"]
KNEE = ["knee_flexion", "knee_adduction", "knee_rotation", "knee_tx", "knee_ty", "knee_tz"]


@pytest.fixture(scope="module")
def gait():
    ref = read_forces(G / "inverse_dynamics.sto")
    r = run_inverse_dynamics(G / "subject01_simbody.osim", G / "subject01_walk1_ik.mot",
                             G / "subject01_walk1_grf.mot", times=ref.time)
    return r, ref


@pytest.fixture(scope="module")
def jw():
    ref = read_forces(J / "reducepoly_subject_GC" / "ID" / "ID_ngait_og5.mat")
    cycle = (ref.time >= 2.178) & (ref.time <= 3.283)      # right heel strike to right heel strike (SOURCE.md)
    r = run_inverse_dynamics(JW_MODEL, J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat",
                             J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat", times=ref.time[cycle])
    return r, ref


def test_gait2354_every_coordinate_against_opensim_46(gait):
    """OpenSim 4.6's InverseDynamicsTool on the same files: all 23 generalized forces."""
    r, _ = gait
    ref = read_forces(OPENSIM46)
    c = compare(r, ref, r.coordinate_names)
    for k in FLEXION_R:
        assert c[k]["percent"] <= 2.0, (k, c[k])            # the target
    for k, v in c.items():
        assert v["rms"] < 0.01 and v["percent"] < 0.05, (k, v)   # measured: <= 0.004 N m, 0.01 %
    assert r.plates == {"plate1": "right", "plate2": "left"}   # as the ExternalLoads XML says
    assert r.residual.max() < 1e-8


def test_gait2354_right_leg_against_shipped_reference(gait):
    """The example's own inverse_dynamics.sto (older OpenSim): hip and ankle within 2 %.

    Its knee differs from OpenSim 4.6's by 3.1 % of peak (and ours equals OpenSim 4.6's,
    test above), so the knee is held to what OpenSim 4.6 itself achieves against it.
    """
    r, ref = gait
    c = compare(r, ref, FLEXION_R)
    assert c["hip_flexion_r"]["percent"] <= 2.0          # measured 1.51 %
    assert c["ankle_angle_r"]["percent"] <= 2.0          # measured 0.15 %
    osim46 = read_forces(OPENSIM46)
    knee46 = np.interp(ref.time, osim46.time, osim46.columns["knee_angle_r_moment"]) - ref.columns["knee_angle_r_moment"]
    gap46 = 100 * np.sqrt(np.mean(knee46 ** 2)) / np.max(np.abs(ref.columns["knee_angle_r_moment"]))
    assert abs(c["knee_angle_r"]["percent"] - gap46) < 0.05, (c["knee_angle_r"], gap46)   # both 3.08 %


@pytest.mark.skipif(importlib.util.find_spec("opensim") is None,
                    reason="optional cross-check: the 'opensim' package is not installed (pip install opensim)")
def test_opensim_live_crosscheck(gait, tmp_path):
    """Run OpenSim's InverseDynamicsTool now (own process: its wheel carries its own CasADi)."""
    r, _ = gait
    out = tmp_path / "id.sto"
    proc = subprocess.run([sys.executable, str(Path(__file__).with_name("opensim_id_reference.py")),
                           str(G / "subject01_simbody.osim"), str(G / "subject01_walk1_ik.mot"),
                           str(G / "subject01_walk1_grf.xml"), "0.4", "1.6", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    live, stored = read_forces(out), read_forces(OPENSIM46)
    for name in stored.columns:
        np.testing.assert_allclose(live.columns[name], stored.columns[name], atol=1e-6, err_msg=name)
    for k, v in compare(r, live, r.coordinate_names).items():
        assert v["rms"] < 0.01, (k, v)


def test_jw_six_knee_generalized_forces_against_opensim(jw):
    r, ref = jw
    c = compare(r, ref, KNEE)
    for k in KNEE:
        assert c[k]["percent"] <= 2.0, (k, c[k])      # measured: flexion 1.98 %, the others below 0.7 %
    assert r.plates["plate2"] == "right" and r.plates["plate1"] == "left"    # SOURCE.md
    # Speed (issue target: 5 s from files to results) is measured by scripts/gait_tables.py,
    # not asserted here: a timed test fails on a busy machine, not on slow code.
    assert any("toes" in w and "triangle inequality" in w for w in r.warnings)


def test_lagrange_prescription_equals_jourdain_projection(gait):
    """Phi = lambda A plus inputs equals J^T (M u' - f) computed without any constraint."""
    r, _ = gait
    e, S = r.eqs, r.states
    f0 = ca.substitute(e.forces, e.inputs, ca.SX.zeros(e.inputs.shape))
    fn = ca.Function("f", [e.q, e.u], [e.mass_matrix, f0])
    for n in range(0, len(r.t), 9):
        M, f = (np.asarray(x) for x in fn(S["q"][n], S["u"][n]))
        Q = S["J"][n].T @ (M @ S["udot"][n] - f.ravel() - S["fext"][n])
        np.testing.assert_allclose(r.generalized_forces[n], Q, atol=1e-8 * (1 + np.abs(Q).max()))


def test_locked_knee_directions_give_lambda_and_transfer_by_equipollence(jw):
    r, _ = jw
    e, S = r.eqs, r.states
    names = r.coordinate_names
    for k in KNEE[1:]:      # eq. (44): a locked coordinate's multiplier is its generalized force
        np.testing.assert_allclose(r.loads[f"knee.{k}.lambda"], r.generalized_force(k), atol=1e-9)
    # the knee's constraint loads moved to arbitrary points by eqs. (32-33) give the same Phi
    rng = np.random.default_rng(3)
    bodies = list(r.model.bodies)
    idx = [names.index(k) for k in KNEE]
    parts = []
    for body in ("femoral_component", "tibial_tray"):
        b = r.model.bodies[body]
        pt = b.point(f"test_{body}", rng.normal(scale=0.2, size=3))
        parts.append((bodies.index(body), e.load_about_function(f"knee@{body}", pt), ca.Function("x", [e.q], [pt.position])))
    for n in range(0, len(r.t), 20):
        total = np.zeros(len(names))
        for k, fn, pos in parts:
            F, MA = (np.asarray(x).ravel() for x in fn(S["q"][n], S["u"][n], r.t[n], r.lam[n]))
            xa, xbar = np.asarray(pos(S["q"][n])).ravel(), S["q"][n][7 * k:7 * k + 3]
            Jv, Jw = S["J"][n][6 * k:6 * k + 3], S["J"][n][6 * k + 3:6 * k + 6]
            JvA = Jv - np.cross(xa - xbar, Jw.T).T          # d v_A / d pdot (eq. 37)
            total += F @ JvA + MA @ Jw                       # eq. (35)-(36)
        # flexion is free (its generalized force is the input); the locked ones are lambda
        expected = [0.0] + [r.generalized_force(c)[n] for c in KNEE[1:]]
        np.testing.assert_allclose(total[idx], expected, atol=1e-7 * (1 + np.abs(expected).max()))


def _copy_motion(tmp_path, drop=None, add=None, nan_row=None):
    lines = (G / "subject01_walk1_ik.mot").read_text().splitlines()
    end = next(i for i, s in enumerate(lines) if s.strip() == "endheader")
    head = [s for s in lines[:end] if not s.startswith(("nRows", "nColumns"))]
    names = lines[end + 1].split("\t")
    rows = [s.split("\t") for s in lines[end + 2:] if s.strip()]
    if drop:
        i = names.index(drop)
        names.pop(i)
        for r in rows:
            r.pop(i)
    if add:
        names.append(add)
        for r in rows:
            r.append("0")
    if nan_row is not None:
        rows[nan_row][5] = "nan"
    p = tmp_path / "ik.mot"
    p.write_text("\n".join(head + ["endheader", "\t".join(names)] + ["\t".join(r) for r in rows]) + "\n")
    return p


def test_bad_inputs_name_the_file_and_the_thing(tmp_path):
    model, grf = G / "subject01_simbody.osim", G / "subject01_walk1_grf.mot"
    with pytest.raises(GaitError, match=r"ik\.mot: missing column\(s\) for the model coordinate\(s\) \['knee_angle_r'\]"):
        run_inverse_dynamics(model, _copy_motion(tmp_path, drop="knee_angle_r"), grf)
    with pytest.raises(GaitError, match=r"ik\.mot: coordinate\(s\) \['knee_tx_r'\] are not in the model"):
        run_inverse_dynamics(model, _copy_motion(tmp_path, add="knee_tx_r"), grf)
    with pytest.raises(DataFileError, match=r"ik\.mot, line \d+, column 6: value of 'pelvis_ty' at t = 0.45 is nan"):
        run_inverse_dynamics(model, _copy_motion(tmp_path, nan_row=3), grf)
    short = tmp_path / "grf.mot"
    text = grf.read_text().splitlines()
    short.write_text("\n".join([s for s in text[:7] if not s.startswith("nRows")] + text[7:700]) + "\n")
    # forces that end before the motion: the overlap is used (issue 15); a window past it is refused
    assert run_inverse_dynamics(model, G / "subject01_walk1_ik.mot", short).t[-1] == pytest.approx(1.15, abs=1e-6)
    with pytest.raises(GaitError, match=r"window 0\.4 \.\.\. 1\.6 s is not inside the time both files cover "
                                        r"\(0\.4 \.\.\. 1\.1533 s\): the motion .*ik\.mot covers 0\.4 \.\.\. 1\.6 s, "
                                        r"the ground reactions .*grf\.mot cover 0 \.\.\. 1\.1533 s"):
        run_inverse_dynamics(model, G / "subject01_walk1_ik.mot", short, start=0.4, end=1.6)
    with pytest.raises(GaitError, match="window 0.2 ... 1 s is not inside"):
        run_inverse_dynamics(model, G / "subject01_walk1_ik.mot", grf, start=0.2, end=1.0)
    # move the left plate's centre of pressure 2 m sideways: nobody stands there
    g = read_grf(grf)
    names = ["time", *g.names]
    g.columns["1_ground_force_pz"] = g.columns["1_ground_force_pz"] + 2.0
    far = tmp_path / "far.mot"
    far.write_text("endheader\n" + "\t".join(names) + "\n" + "\n".join(
        "\t".join(repr(float(v)) for v in [g.time[i], *(g.columns[n][i] for n in g.names)]) for i in range(len(g.time))) + "\n")
    with pytest.raises(GaitError, match=r"far\.mot: plate2 is loaded .* but no foot stands on it"):
        run_inverse_dynamics(model, G / "subject01_walk1_ik.mot", far)
    assert issubclass(GaitError, OcpConstraintsError)


def test_cli_writes_results_and_reports_bad_input(tmp_path, capsys):
    import argparse
    import json

    p = argparse.ArgumentParser()
    add_gait_parser(p.add_subparsers(dest="command"))
    args = p.parse_args(["gait", "--model", str(G / "subject01_simbody.osim"), "--motion", str(G / "subject01_walk1_ik.mot"),
                         "--grf", str(G / "subject01_walk1_grf.mot"), "--out", str(tmp_path / "out"), "--no-plots"])
    assert cli_gait(args) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["plates"] == {"plate1": "right", "plate2": "left"}
    assert "knee_r" in summary["leg_joints"] and summary["leg_joints"]["knee_r"]["inputs"] == ["knee_angle_r"]
    header = (tmp_path / "out" / "loads.csv").read_text().splitlines()[0].split(",")
    for col in ("t", "knee_angle_r_moment", "pelvis_tx_force", "knee_r.translation1.lambda",
                "knee_r@tibia_r.F_x", "knee_r@femur_r.M_z", "knee_r@tibia_r.point_y", "knee_r@tibia_r.power"):
        assert col in header
    args.motion = str(tmp_path / "missing.mot")
    assert cli_gait(args) == 2
    assert "missing.mot: does not exist" in capsys.readouterr().err
