"""Data robustness of gait/knee (issue 15): time stamps rounded differently, real gaps, the
low-pass cutoff, angle units, and knee data that belong to one model file only."""
import argparse
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.biomech.gait import run_inverse_dynamics
from ocp_constraints.biomech.opensim_files import read_motion
from ocp_constraints.errors import DataFileError, GaitError, KneeError

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
G = DATA / "opensim-gait2354-subject01"
J = DATA / "grand-challenge-knee-jw"
JW_MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
MODEL, IK, GRF = G / "subject01_simbody.osim", G / "subject01_walk1_ik.mot", G / "subject01_walk1_grf.mot"


def _grf_from(tmp_path, t_min, first_time=None, t_max=None, name="grf.mot") -> Path:
    """The gait2354 force file cut to ``t_min ... t_max``, its first time stamp rewritten (another rounding)."""
    lines = GRF.read_text().splitlines()
    end = next(k for k, line in enumerate(lines) if line.strip().lower() == "endheader")
    head = [line for line in lines[:end + 2] if not line.startswith("nRows")]
    rows = [r for r in lines[end + 2:] if t_min - 1e-9 <= float(r.split()[0]) <= (t_max or 1e9)]
    if first_time is not None:
        parts = rows[0].split("\t")
        parts[0] = first_time
        rows[0] = "\t".join(parts)
    out = tmp_path / name
    out.write_text("\n".join(head + rows) + "\n")
    return out


@pytest.fixture(scope="module")
def reference():
    return run_inverse_dynamics(MODEL, IK, GRF)


def test_files_whose_time_stamps_differ_by_a_rounding_run_and_say_so(tmp_path, reference):
    # motion starts at 0.4 s (rounded to 4 decimals), forces at 0.40003 s (5 decimals): one instant
    grf = _grf_from(tmp_path, 0.4, "0.40003")
    r = run_inverse_dynamics(MODEL, IK, grf)
    assert len(r.t) == 73 and r.t[0] == pytest.approx(0.4)
    # the motion samples fall on force samples of the original file: the same loads
    np.testing.assert_allclose(r.generalized_forces, reference.generalized_forces, atol=1e-8)
    notes = r.settings["timing"]["notes"]
    assert any("starts 3e-05 s before the ground reactions" in n and "same instant" in n for n in notes)
    assert r.settings["timing"]["tolerance_s"] == pytest.approx(0.5 / 60, rel=1e-4)


def test_the_overlap_is_used_and_only_real_gaps_fail_naming_both_ranges(tmp_path, reference):
    grf = _grf_from(tmp_path, 0.8, t_max=1.3)                 # forces cover only part of the motion
    r = run_inverse_dynamics(MODEL, IK, grf)
    assert r.t[0] == pytest.approx(0.8) and r.t[-1] == pytest.approx(1.3)
    keep = (reference.t >= 0.8 - 1e-9) & (reference.t <= 1.3 + 1e-9)
    np.testing.assert_allclose(r.generalized_forces, reference.generalized_forces[keep], atol=1e-8)
    with pytest.raises(GaitError, match=r"not inside the time both files cover \(0\.8 \.\.\. 1\.3 s\): the motion "
                                        r".*ik\.mot covers 0\.4 \.\.\. 1\.6 s, the ground reactions .*grf\.mot cover "
                                        r"0\.8 \.\.\. 1\.3"):
        run_inverse_dynamics(MODEL, IK, grf, start=0.5, end=1.2)
    late = _grf_from(tmp_path, 1.9, name="late.mot")
    with pytest.raises(GaitError, match=r"do not overlap: the motion .* covers 0\.4 \.\.\. 1\.6 s, the ground "
                                        r"reactions .*late\.mot cover 1\.9 \.\.\. 2\.5 s"):
        run_inverse_dynamics(MODEL, IK, late)
    lines = GRF.read_text().splitlines()                        # 0.2 s of force samples missing inside the window
    gap = tmp_path / "gap.mot"
    gap.write_text("\n".join(r for r in lines if not r.startswith("nRows") and
                             (not r[:1].isdigit() or not 1.0 < float(r.split()[0]) < 1.2)) + "\n")
    with pytest.raises(GaitError, match=r"gap\.mot: the ground-reaction record has a gap from 1 to 1\.2 s"):
        run_inverse_dynamics(MODEL, IK, gap)


@pytest.mark.parametrize("cutoff, message", [
    (31.0, r"cutoff 31 Hz is at or above the Nyquist frequency 30 Hz of the motion .*ik\.mot \(sampled at 60 Hz\)"),
    (100.0, r"cutoff 100 Hz is at or above the Nyquist frequency 30 Hz"),
    (30.0, r"cutoff 30 Hz is at or above the Nyquist"),
    (-1.0, r"cutoff -1.0 Hz is not a positive frequency: .*--no-filter"),
    (0.0, r"cutoff 0.0 Hz is not a positive frequency"),
    (float("nan"), r"cutoff nan Hz is not a positive frequency"),
])
def test_an_invalid_cutoff_is_refused(cutoff, message):
    with pytest.raises(GaitError, match=message):
        run_inverse_dynamics(MODEL, IK, GRF, cutoff=cutoff)


def test_cli_records_every_filter_setting_and_filters_off_only_on_request(tmp_path, capsys):
    from ocp_constraints.cli.gait import add_gait_parser, cli_gait

    p = argparse.ArgumentParser()
    add_gait_parser(p.add_subparsers(dest="command"))
    base = ["gait", "--model", str(MODEL), "--motion", str(IK), "--grf", str(GRF), "--no-plots"]
    assert cli_gait(p.parse_args(base + ["--out", str(tmp_path / "a"), "--cutoff", "8"])) == 0
    f = json.loads((tmp_path / "a" / "summary.json").read_text())["filter"]["coordinates"]
    assert f["applied"] and f["cutoff_hz"] == 8.0 and f["nyquist_hz"] == pytest.approx(30.0, rel=1e-5)
    assert "3rd order" in f["filter"] and "quintic" in f["splines"]
    assert cli_gait(p.parse_args(base + ["--out", str(tmp_path / "b"), "--no-filter"])) == 0
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert s["filter"]["coordinates"]["applied"] is False and s["filter"]["coordinates"]["cutoff_hz"] is None
    assert s["inputs"]["no_filter"] is True
    assert cli_gait(p.parse_args(base + ["--out", str(tmp_path / "c"), "--cutoff", "45"])) == 2
    assert "Nyquist frequency 30 Hz" in capsys.readouterr().err
    with pytest.raises(SystemExit):          # both at once: argparse refuses
        p.parse_args(base + ["--out", str(tmp_path / "d"), "--cutoff", "6", "--no-filter"])


def _motion_text(inDegrees: str | None, rows) -> str:
    head = ["test", "version=1", f"nRows={len(rows)}", "nColumns=3"]
    if inDegrees is not None:
        head.append(f"inDegrees={inDegrees}")
    return "\n".join(head + ["endheader", "time\tknee_angle_r\tpelvis_tx"] +
                     ["\t".join(f"{v:.8g}" for v in r) for r in rows]) + "\n"


def test_degrees_given_as_radians_and_the_reverse_are_detected(tmp_path):
    t = np.linspace(0, 1, 11)
    deg_rows = [(ti, -60 * np.sin(3 * ti), 0.1 * ti) for ti in t]        # knee -60 ... 0 degrees
    rad_rows = [(ti, np.radians(-60 * np.sin(3 * ti)), 0.1 * ti) for ti in t]
    (tmp_path / "a.mot").write_text(_motion_text("no", deg_rows))
    with pytest.raises(DataFileError, match=r"a\.mot: says inDegrees=no in its header, but its angles look like "
                                            r"degrees \('knee_angle_r' reaches 59\.8.*no joint angle in radians "
                                            r"exceeds 2 pi\): correct the header"):
        read_motion(tmp_path / "a.mot")
    (tmp_path / "b.mot").write_text(_motion_text("yes", rad_rows))
    with pytest.raises(DataFileError, match=r"b\.mot: says inDegrees=yes in its header, but its angles look like "
                                            r"radians .*within 3\.2 degrees"):
        read_motion(tmp_path / "b.mot")
    # radians labelled degrees, the heading of a subject walking along -x (a global angle near pi) among the joints
    turned = tmp_path / "turned.mot"
    cols = {"pelvis_rotation": np.pi + 0.05 * t, "hip_flexion_r": 0.5 * np.sin(3 * t),
            "knee_angle_r": np.radians(-60 * np.sin(3 * t)), "ankle_angle_r": 0.2 * np.cos(3 * t)}
    turned.write_text("\n".join(["turned", "version=1", f"nRows={len(t)}", f"nColumns={len(cols) + 1}", "inDegrees=yes",
                                 "endheader", "\t".join(["time", *cols])]
                                + ["\t".join(f"{v:.8g}" for v in (ti, *(c[k] for c in cols.values())))
                                   for k, ti in enumerate(t)]) + "\n")
    with pytest.raises(DataFileError, match=r"turned\.mot: says inDegrees=yes in its header, but its angles look like "
                                            r"radians \('knee_angle_r' moves by 1\.04.*within 3\.2 degrees"):
        read_motion(turned)
    # no inDegrees line (assumed radians): the range decides and the note says so
    (tmp_path / "c.mot").write_text(_motion_text(None, deg_rows))
    m = read_motion(tmp_path / "c.mot")
    np.testing.assert_allclose(m["knee_angle_r"], np.radians([r[1] for r in deg_rows]), atol=1e-9)
    assert "range says degrees" in m.metadata["angle_unit_note"]
    # a JW-style CSV without header is taken as degrees, unless its range says radians
    (tmp_path / "d.csv").write_text("time,knee_angle_r,pelvis_tx\n" + "\n".join(",".join(f"{v:.10g}" for v in r)
                                                                              for r in rad_rows) + "\n")
    m = read_motion(tmp_path / "d.csv")
    np.testing.assert_allclose(m["knee_angle_r"], [r[1] for r in rad_rows], atol=1e-9)
    assert "range says radians" in m.metadata["angle_unit_note"]
    # the caller's word is final; an ambiguous range keeps the header's unit
    assert read_motion(tmp_path / "a.mot", in_degrees=True)["knee_angle_r"][3] == pytest.approx(np.radians(deg_rows[3][1]))
    still = [(ti, 2.0, 0.0) for ti in t]                 # 2 (degrees or radians?) held still: no verdict
    (tmp_path / "e.mot").write_text(_motion_text("yes", still))
    assert read_motion(tmp_path / "e.mot")["knee_angle_r"][0] == pytest.approx(np.radians(2.0))


def test_knee_data_are_found_by_the_model_files_content(tmp_path, monkeypatch):
    from ocp_constraints.biomech import knee_model_data as kd

    monkeypatch.setenv("OCP_CONSTRAINTS_CACHE", str(tmp_path / "cache"))
    jw = kd.knee_model_data(JW_MODEL)
    assert jw.sha256 == "8ec2d2a52d68c249ec7ee1bebc066c82fb97da0c3dc0bc60d3dd2986d93d0e8c"
    assert jw.muscle_paths.name == "jw_knee_muscle_paths.json" and "package data" in jw.source
    renamed = tmp_path / "renamed.osim"                  # same content, other name: the same data
    shutil.copy(JW_MODEL, renamed)
    assert kd.knee_model_data(renamed).muscle_paths == jw.muscle_paths
    other = tmp_path / "other.osim"                      # one byte more: another model, no data
    other.write_bytes(JW_MODEL.read_bytes() + b"\n")
    with pytest.raises(KneeError, match=r"other\.osim: no implant contact geometry for this model file .*"
                                        r"never used for another.*--implant-meshes DIR"):
        kd.knee_model_data(other)
    monkeypatch.setattr(kd, "opensim_available", lambda: False)
    meshes = J / "workshop_bcn2024" / "ExperimentalData"
    with pytest.raises(KneeError, match=r"other\.osim: no muscle-path fits for this model file .*never used for "
                                        r"another.*'opensim' package is not installed: install it"):
        kd.knee_model_data(other, implant_meshes=meshes)
    # the geometry built from the meshes is kept under the model's key (the JW meshes: the JW numbers)
    geo = json.loads((kd.cache_dir() / kd.model_sha256(other) / kd.GEOMETRY_NAME).read_text())["parameters"]
    assert geo == pytest.approx(jw.geometry, abs=1e-12)


def test_cached_fits_of_an_older_preprocessing_are_not_used(tmp_path, monkeypatch):
    """A fits file in the cache made before the moment arms were the string's (issue 15's fifth round: for the
    gastrocnemii, computeMomentArm gave hip arms their path does not have) is refused, naming the file, when it
    cannot be rebuilt; the package's own JW fits carry the current stamp."""
    from ocp_constraints.biomech import knee_model_data as kd

    monkeypatch.setenv("OCP_CONSTRAINTS_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(kd, "opensim_available", lambda: False)
    other = tmp_path / "other.osim"
    other.write_bytes(JW_MODEL.read_bytes() + b"\n")
    folder = kd.cache_dir() / kd.model_sha256(other)
    folder.mkdir(parents=True)
    old = json.loads((kd.DATA_DIR / "jw_knee_muscle_paths.json").read_text())
    assert old.pop("preprocessing") == kd.PREPROCESSING
    (folder / kd.PATHS_NAME).write_text(json.dumps(old))
    shutil.copy(kd.DATA_DIR / "jw_knee_implant_geometry.json", folder / kd.GEOMETRY_NAME)
    with pytest.raises(KneeError, match=r"other\.osim: only muscle-path fits of an older preprocessing \(.*"
                                        r"muscle_paths\.json; made with 'unknown'.*'opensim' package is not installed"):
        kd.knee_model_data(other)
    old["preprocessing"] = kd.PREPROCESSING          # the same file, stamped: used
    (folder / kd.PATHS_NAME).write_text(json.dumps(old))
    assert kd.knee_model_data(other).source.startswith("cache ")


def test_knee_cli_refuses_another_model_without_fits(tmp_path, monkeypatch, capsys):
    from ocp_constraints.biomech import knee_model_data as kd
    from ocp_constraints.cli.knee import add_knee_parser, cli_knee

    monkeypatch.setenv("OCP_CONSTRAINTS_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(kd, "opensim_available", lambda: False)
    other = tmp_path / "OTHER.osim"
    other.write_bytes(JW_MODEL.read_bytes().replace(b"<mass>", b"<mass> ", 1))
    p = argparse.ArgumentParser()
    add_knee_parser(p.add_subparsers(dest="command"))
    args = p.parse_args(["knee", "--model", str(other), "--motion", str(IK), "--grf", str(GRF),
                         "--implant-meshes", str(J / "workshop_bcn2024" / "ExperimentalData"),
                         "--out", str(tmp_path / "out"), "--no-plots"])
    assert cli_knee(args) == 2
    err = capsys.readouterr().err
    assert "OTHER.osim: no muscle-path fits for this model file" in err and "opensim" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not __import__("importlib").util.find_spec("opensim"), reason="optional opensim extra")
def test_the_opensim_preprocessing_refuses_a_model_without_a_jw_knee(tmp_path):
    from ocp_constraints.biomech.knee_model_data import build_muscle_paths

    with pytest.raises(KneeError, match=r"subject01_simbody\.osim: OpenSim's muscle-path sampling failed: .*no "
                                        r"coordinate\(s\) \['hip_flexion', .*JW-type right knee"):
        build_muscle_paths(MODEL, tmp_path / "paths.json", samples=10)
    assert not (tmp_path / "paths.json").exists()


def test_a_selected_window_past_the_files_is_refused():
    with pytest.raises(GaitError, match=r"selected window 0\.3 \.\.\. 1 s reaches past the time both files cover "
                                        r"\(0\.4 \.\.\. 1\.6 s\)"):
        run_inverse_dynamics(MODEL, IK, GRF, select=lambda plates, grf: (0.3, 1.0))
    r = run_inverse_dynamics(MODEL, IK, GRF, select=lambda plates, grf: (0.5, 1.0))
    assert r.t[0] == pytest.approx(0.5) and r.t[-1] == pytest.approx(1.0) and r.settings["timing"]["samples"] == 31


def test_a_csv_saved_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Excel's "CSV UTF-8" starts the file with a BOM; it was read into the first column's name ("\\ufefftime"),
    and the file refused for having no time column, while the message listed a 'time' column."""
    rows = "".join(f"{0.01 * k:.2f},{-0.5 + 0.01 * k:.4f},{0.1 * k:.3f}\n" for k in range(20))
    (tmp_path / "plain.csv").write_text("time,knee_angle_r,pelvis_tx\n" + rows, encoding="utf-8")
    (tmp_path / "bom.csv").write_text("time,knee_angle_r,pelvis_tx\n" + rows, encoding="utf-8-sig")
    assert (tmp_path / "bom.csv").read_bytes()[:3] == b"\xef\xbb\xbf"
    plain, bom = read_motion(tmp_path / "plain.csv"), read_motion(tmp_path / "bom.csv")
    np.testing.assert_array_equal(bom.time, plain.time)
    np.testing.assert_array_equal(bom["knee_angle_r"], plain["knee_angle_r"])


def test_missing_free_torque_columns_are_taken_as_zero_and_said(tmp_path):
    """A force file without a plate's free-torque columns runs (the torque is often not exported) with the torque
    taken as zero, and a warning names the file, the plate and the columns (it was silent: hip rotation moved by
    4.3 N m). Checked against the full file with that plate's torque set to zero by hand."""
    lines = GRF.read_text().splitlines()
    end = next(k for k, line in enumerate(lines) if line.strip().lower() == "endheader")
    names = lines[end + 1].split("\t")
    drop = [names.index(f"ground_torque_{a}") for a in "xyz"]
    rows = [line.split("\t") for line in lines[end + 1:]]
    cut, zeroed = tmp_path / "cut.mot", tmp_path / "zeroed.mot"
    head = [line for line in lines[:end + 1] if not line.startswith("nColumns")]
    cut.write_text("\n".join(head + ["\t".join(v for k, v in enumerate(r) if k not in drop) for r in rows]) + "\n")
    zeroed.write_text("\n".join(lines[:end + 1] + ["\t".join("0" if k in drop and i else v for k, v in enumerate(r))
                                                    for i, r in enumerate(rows)]) + "\n")
    r = run_inverse_dynamics(MODEL, IK, cut)
    np.testing.assert_allclose(r.generalized_forces, run_inverse_dynamics(MODEL, IK, zeroed).generalized_forces,
                               rtol=0, atol=1e-9)
    assert any("cut.mot: plate1 has no free-torque column(s) torque_x, torque_y, torque_z: taken as zero" in w
               for w in r.warnings)


def test_forces_sampled_slower_than_the_motion_are_said_to_be_interpolated(tmp_path, reference):
    """Every 20th row of the 600 Hz force file (30 Hz against the motion's 60 Hz): it runs, and a note says the
    forces are interpolated linearly between their samples (it ran without a word); the full file gets no such note."""
    lines = GRF.read_text().splitlines()
    end = next(k for k, line in enumerate(lines) if line.strip().lower() == "endheader")
    rows = lines[end + 2:]
    slow = tmp_path / "grf_30hz.mot"
    slow.write_text("\n".join([line for line in lines[:end + 2] if not line.startswith("nRows")] + rows[::20]) + "\n")
    r = run_inverse_dynamics(MODEL, IK, slow)
    assert any("ground reactions are sampled at 30 Hz, slower than the motion's 60 Hz: they are interpolated "
               "linearly" in n for n in r.settings["timing"]["notes"])
    assert not any("slower than the motion" in n for n in reference.settings["timing"]["notes"])
