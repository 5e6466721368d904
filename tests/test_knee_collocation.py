"""Knee contact loads by direct collocation with activation dynamics (issue 7, item (b))."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.biomech.knee_muscles import MusclePaths, muscle_parameters

J = Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw"
JW_MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
IK = J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat"
GRF = J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat"
KCF = J / "reducepoly_subject_GC" / "KCF" / "KCF_ngait_og5.mat"


def _rate(e, a, tau_a, tau_d):
    """Independent ``da/dt = (e - a)(e/tau_act + (1 - e)/tau_deact)`` (Raasch et al. 1997)."""
    return (e - a) * (e / tau_a + (1.0 - e) / tau_d)


@pytest.fixture(scope="module")
def stance():
    """20 consecutive frames of stance at the motion's own 120 Hz spacing (1/6 s: several activation time constants;
    40 frames gave the same conclusions at three times the cost)."""
    from ocp_constraints.biomech.gait import run_inverse_dynamics
    from ocp_constraints.biomech.knee_model import contact_matrix_function
    from ocp_constraints.biomech.knee_static import frame_data

    t = 2.3 + np.arange(20) / 120.0
    gait = run_inverse_dynamics(JW_MODEL, IK, GRF, times=t)
    paths = MusclePaths()
    Qc, R, A = frame_data(gait, paths, contact_matrix_function())
    F0 = np.array([muscle_parameters(JW_MODEL, paths.muscles)[m].max_isometric_force for m in paths.muscles])
    return gait.t, Qc, R, A, F0


@pytest.fixture(scope="module")
def realistic(stance):
    """The collocation solution with the default (De Groote et al. 2016) time constants, shared by two tests."""
    from ocp_constraints.biomech.knee_collocation import solve_collocation

    return solve_collocation(*stance)


def test_fast_activation_limit_is_the_static_optimisation(stance, realistic):
    """tau -> 0: the collocation loads approach the static ones frame by frame (cold start, no static guess)."""
    from ocp_constraints.biomech.knee_collocation import solve_collocation
    from ocp_constraints.biomech.knee_static import solve_static

    t, Qc, R, A, F0 = stance
    st = solve_static(t, Qc, R, A, F0)
    errs = []
    for tau in (0.001, 0.0005):
        col = solve_collocation(t, Qc, R, A, F0, tau_act=tau, tau_deact=tau, warm_start=False)
        assert col.status == "Solve_Succeeded"
        errs.append(max(np.abs(col.medial - st.medial).max(), np.abs(col.lateral - st.lateral).max()))
        assert np.all(col.medial >= -1e-8) and np.all(col.lateral >= -1e-8)
    # first order in tau (backward Euler on the activation): halving tau about halves the difference (measured
    # 35.7 -> 19.3 N with OpenSim's moment arms; 4 ms 90.8 N, 0.25 ms 9.9 N), within 5 % of a body weight at 0.5 ms
    assert errs[1] < 0.6 * errs[0]
    assert errs[1] < 0.05 * 614.25
    # a realistic (slow) activation changes the loads: the limit is not trivially met
    slow = realistic
    assert max(np.abs(slow.medial - st.medial).max(), np.abs(slow.lateral - st.lateral).max()) > errs[1]


def test_activation_ode_residual_and_contact_signs(stance, realistic):
    """Backward-Euler (Radau IIA) defects recomputed independently <= 1e-8; N >= -1e-8; bounds on a, e."""
    from ocp_constraints.biomech.knee_collocation import TAU_ACT, TAU_DEACT

    t, Qc, R, A, F0 = stance
    col = realistic
    a, e = col.activation, col.excitation
    h = np.diff(t)[:, None]
    d = a[1:] - a[:-1] - h * _rate(e[1:], a[1:], TAU_ACT, TAU_DEACT)
    d0 = a[1] - a[0] - h[0] * _rate(e[0], a[0], TAU_ACT, TAU_DEACT)
    assert np.abs(d).max() <= 1e-8 and np.abs(d0).max() <= 1e-8
    assert col.ode_residual <= 1e-8
    assert np.all(col.medial >= -1e-8) and np.all(col.lateral >= -1e-8)
    assert a.min() >= -1e-8 and a.max() <= 1 + 1e-8 and e.min() >= -1e-8 and e.max() <= 1 + 1e-8
    # the generalized-force balance of the static problem holds at every frame
    res = np.einsum("ncm,nm->nc", R, col.force) + np.einsum("njc,nj->nc", A, col.lam) - Qc
    res[:, :6] += col.reserve
    assert np.abs(res).max() < 1e-6


def test_failed_solve_names_ipopt_status(stance):
    from ocp_constraints.biomech.knee_collocation import solve_collocation
    from ocp_constraints.errors import KneeError

    t, Qc, R, A, F0 = stance
    with pytest.raises(KneeError, match="IPOPT status 'Maximum_Iterations_Exceeded'"):
        solve_collocation(t, Qc, R, A, F0, max_iter=2, warm_start=False)


def _every_kth_frame_csv(path: Path, k: int) -> np.ndarray:
    """The IK motion with every k-th frame only, as a JW-style .csv (degrees); returns its times."""
    import scipy.io

    mat = scipy.io.loadmat(str(IK), squeeze_me=True, struct_as_record=False)
    s = next(v for key, v in mat.items() if not key.startswith("__"))
    data = np.asarray(s.data, float)[::k]
    path.write_text(",".join(str(n) for n in s.colheaders) + "\n"
                    + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in data))
    return data[:, 0]


def test_cli_collocation_writes_summary(tmp_path):
    """The command on the whole gait cycle, with the motion thinned to every 4th frame (30 Hz, ~33 frames)
    so the NLP is small; its files are checked against values recomputed from them and the raw data.

    (The full 120 Hz cycle, 133 frames, takes ~1.5 min on 2 cores: ``ocp-constraints knee ... --method
    collocation`` on the original IK file.)
    """
    import scipy.io

    from ocp_constraints.biomech.knee_collocation import TAU_ACT, TAU_DEACT
    from ocp_constraints.cli.main import main

    motion = tmp_path / "ik_30hz.csv"
    t_motion = _every_kth_frame_csv(motion, 4)
    out = tmp_path / "col"
    assert main(["knee", "--model", str(JW_MODEL), "--motion", str(motion), "--grf", str(GRF), "--measured", str(KCF),
                 "--method", "collocation", "--out", str(out), "--no-plots"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["method"] == "collocation" and s["success"] is True
    assert s["solver"]["status"] == "Solve_Succeeded"
    t0, t1 = s["gait_cycle_s"]
    in_cycle = t_motion[(t_motion >= t0 - 1e-9) & (t_motion <= t1 + 1e-9)]
    assert s["frames"] == len(in_cycle) >= 30                 # the thinned motion's frames in the cycle
    tab = np.genfromtxt(out / "loads.csv", delimiter=",", names=True, deletechars="")
    assert np.allclose(tab["t"], in_cycle, rtol=0, atol=1e-9)
    # activation dynamics, backward Euler on the frames, recomputed from loads.csv with the independent rate
    muscles = [n[: -len(".activation")] for n in tab.dtype.names if n.endswith(".activation")]
    a = np.column_stack([tab[f"{m}.activation"] for m in muscles])
    e = np.column_stack([tab[f"{m}.excitation"] for m in muscles])
    h = np.diff(tab["t"])[:, None]
    assert np.abs(a[1:] - a[:-1] - h * _rate(e[1:], a[1:], TAU_ACT, TAU_DEACT)).max() <= 1e-8
    assert s["solver"]["max_activation_ode_residual"] <= 1e-8
    assert np.all(tab["N_medial"] >= -1e-8) and np.all(tab["N_lateral"] >= -1e-8)
    # the comparison, recomputed from loads.csv and the raw KCF file (medial = PM + AM, lbf -> N) in body
    # weights from the .osim masses and gravity
    kcf = next(v for key, v in scipy.io.loadmat(str(KCF), squeeze_me=True, struct_as_record=False).items()
               if not key.startswith("__"))
    cols = [str(c) for c in kcf.colheaders]
    d = np.asarray(kcf.data, float)
    medial = (d[:, cols.index("PM")] + d[:, cols.index("AM")]) * 4.4482216153
    osim = JW_MODEL.read_text()
    gravity = np.linalg.norm([float(x) for x in re.search(r"<gravity>([^<]*)</gravity>", osim).group(1).split()])
    bw = sum(float(m) for m in re.findall(r"<mass>([^<]*)</mass>", osim)) * gravity
    assert s["body_weight_N"] == pytest.approx(bw, rel=1e-12)
    rmse = np.sqrt(np.mean((tab["N_medial"] - np.interp(tab["t"], d[:, 0], medial)) ** 2)) / bw
    assert set(s["comparison"]) == {"medial", "lateral", "total"}
    assert s["comparison"]["medial"]["rmse_bw"] == pytest.approx(rmse, rel=1e-9)


def test_a_failed_collocation_keeps_the_static_loads_and_says_so(tmp_path, monkeypatch, capsys):
    """IPOPT stopped after 2 iterations (a real failure, Maximum_Iterations_Exceeded) on the collocation: the command
    still writes loads, the static optimisation's (the collocation's starting point), and says so in summary.json
    and on stderr; they are those of ``--method static`` on the same files."""
    import ocp_constraints.biomech.knee_collocation as kc
    from ocp_constraints.cli.main import main

    real = kc.solve_collocation
    monkeypatch.setattr(kc, "solve_collocation", lambda *a, **k: real(*a, **{**k, "max_iter": 2}))
    motion = tmp_path / "ik_30hz.csv"
    _every_kth_frame_csv(motion, 4)
    args = ["knee", "--model", str(JW_MODEL), "--motion", str(motion), "--grf", str(GRF), "--no-plots"]
    assert main(args + ["--out", str(tmp_path / "fell_back")]) == 0
    s = json.loads((tmp_path / "fell_back" / "summary.json").read_text())
    assert s["method"] == "static" and s["inputs"]["method"] == "collocation"
    assert "Maximum_Iterations_Exceeded" in s["fallback"] and "static optimisation" in s["fallback"]
    assert "warning: collocation failed" in capsys.readouterr().err
    assert main(args + ["--method", "static", "--out", str(tmp_path / "static")]) == 0
    fell = np.genfromtxt(tmp_path / "fell_back" / "loads.csv", delimiter=",", names=True, deletechars="")
    static = np.genfromtxt(tmp_path / "static" / "loads.csv", delimiter=",", names=True, deletechars="")
    assert fell.dtype.names == static.dtype.names
    for name in ("N_medial", "N_lateral", "N_total"):
        assert np.array_equal(fell[name], static[name])


def test_a_failed_static_optimisation_writes_its_last_iterate_and_exits_1(tmp_path, monkeypatch, capsys):
    """IPOPT stopped after 2 iterations on the static optimisation (a real failure, Maximum_Iterations_Exceeded;
    a trial with ground reactions 30 times too large failed so after 42 s): the command writes the last iterate
    with ``"success": false`` and IPOPT's status, says so, and exits 1 (it exited 2 with nothing written)."""
    import ocp_constraints.biomech.knee_static as ks
    from ocp_constraints.cli.main import main

    real = ks.ipopt_solver
    monkeypatch.setattr(ks, "ipopt_solver", lambda name, nlp, options: real(name, nlp, {**options, "ipopt.max_iter": 2}))
    motion = tmp_path / "ik_30hz.csv"
    _every_kth_frame_csv(motion, 4)
    out = tmp_path / "failed"
    assert main(["knee", "--model", str(JW_MODEL), "--motion", str(motion), "--grf", str(GRF), "--no-plots",
                 "--method", "static", "--out", str(out)]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["success"] is False and s["status"] == "Maximum_Iterations_Exceeded" and s["method"] == "static"
    assert "error: IPOPT did not solve the muscle forces (status 'Maximum_Iterations_Exceeded')" in capsys.readouterr().err
    loads = np.genfromtxt(out / "loads.csv", delimiter=",", names=True, deletechars="")
    assert len(loads["t"]) == s["frames"] > 0


def _grf_csv_without(path: Path, lo: float, hi: float) -> None:
    """The JW ground reactions as a .csv (same column names), the samples strictly between ``lo`` and ``hi`` s left out."""
    import scipy.io

    mat = scipy.io.loadmat(str(GRF), squeeze_me=True, struct_as_record=False)
    s = next(v for key, v in mat.items() if not key.startswith("__"))
    data = np.asarray(s.data, float)
    data = data[~((data[:, 0] > lo) & (data[:, 0] < hi))]
    path.write_text(",".join(str(n) for n in s.colheaders) + "\n"
                    + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in data))


def test_a_gap_in_the_records_outside_the_gait_cycle_leaves_the_cycles_loads_alone(tmp_path):
    """Ground reactions missing for 0.2 s after the cycle (2.178-3.283 s): the knee ran the gap check over the whole
    overlap of the files and refused the trial; now only the cycle it selects must be gap-free. The cycle's loads are
    those of the complete record, and a gap inside the cycle is still refused naming the file and the window."""
    from ocp_constraints.biomech.knee_pipeline import run_knee
    from ocp_constraints.errors import GaitError

    motion = tmp_path / "ik_30hz.csv"
    _every_kth_frame_csv(motion, 4)
    whole, after, inside = tmp_path / "grf.csv", tmp_path / "grf_gap_after.csv", tmp_path / "grf_gap_inside.csv"
    _grf_csv_without(whole, 0.0, 0.0)
    _grf_csv_without(after, 3.6, 3.8)
    _grf_csv_without(inside, 2.6, 2.8)
    ref = run_knee(JW_MODEL, motion, whole, method="static")["result"]
    gapped = run_knee(JW_MODEL, motion, after, method="static")["result"]
    np.testing.assert_array_equal(gapped.t, ref.t)
    np.testing.assert_allclose(gapped.total, ref.total, rtol=0, atol=1e-9)
    with pytest.raises(GaitError, match=r"grf_gap_inside\.csv: the ground-reaction record has a gap from 2\.599.* "
                                        r"inside the window 2\.17"):
        run_knee(JW_MODEL, motion, inside, method="static")
