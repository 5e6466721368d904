"""Issue 15: the knee's modelling candidates, one at a time, measured against the eTibia loads.

    python scripts/knee_candidates.py [--out results/knee] [--plot-only]   (--plot-only: C6 and the plot only)

Runs the inverse dynamics of ngait_og5 once, then the static optimisation with one change
at a time (and the adopted combination), and writes ``candidates.md`` / ``candidates.json``:
RMSE (BW), R^2 and peak error per compartment, the mean lateral force in mid-stance
(2.43-2.60 s) and the late-stance total peak (2.65-2.85 s), the peak reserves; and ``before_after.png`` from the ``knee`` runs in
``<out>/before`` and ``<out>`` (the README's commands). The measured
loads are used here for the table only; nothing is fitted to them.

Candidates that need OpenSim (the muscles' moment arms by OpenSim's own
``computeMomentArm`` at the trial's poses) run it in its own process (the ``opensim``
extra); without it they are skipped. jw_ngait_og1 (workshop folder) cannot be run: that
folder has no ground reactions for it, and without them there is no inverse dynamics.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.gait import run_inverse_dynamics  # noqa: E402
from ocp_constraints.biomech.knee_model import contact_matrix_function  # noqa: E402
from ocp_constraints.biomech.knee_muscles import PRIMARY, SECONDARY, MusclePaths, muscle_parameters  # noqa: E402
from ocp_constraints.biomech.knee_passive import HIP_KNEE_ANKLE, passive_generalized_forces, passive_hip_moment  # noqa: E402,E501
from ocp_constraints.biomech.knee_pipeline import gait_cycle, read_measured  # noqa: E402
from ocp_constraints.biomech.knee_quadriceps import patellar_ligament_arms  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED, frame_data  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIAL = {k: J / "reducepoly_subject_GC" / k / f"{k}_ngait_og5.mat" for k in ("IK", "GRF", "KCF")}
ROWS = RESERVED + SECONDARY
MID, LATE = (2.43, 2.60), (2.65, 2.85)

OPENSIM_ARMS = r'''
import json, sys, numpy as np, opensim as osim
d = json.load(open(sys.argv[2]))
model = osim.Model(sys.argv[1]); state = model.initSystem(); cs = model.getCoordinateSet()
for i in range(cs.getSize()):
    cs.get(i).setLocked(state, False)
ms = model.getMuscles(); P = np.array(d["P"]); names = d["names"]
out = np.zeros((len(P), len(d["rows"]), len(d["muscles"])))
for n in range(len(P)):
    for j, c in enumerate(names):
        if cs.contains(c):
            cs.get(c).setValue(state, float(P[n, j]), False)
    cs.get("patfem_flexion").setValue(state, float(P[n, names.index("knee_flexion")]) + 1.57, False)
    model.realizePosition(state)
    for k, m in enumerate(d["muscles"]):
        for j, c in enumerate(d["rows"]):
            out[n, j, k] = ms.get(m).computeMomentArm(state, cs.get(c))
json.dump(out.tolist(), open(sys.argv[3], "w"))
'''


def solve(Qc, R, A, F0, power=2, reserve_weights=None, contact_weight=0.0, scale=1000.0, activation_weights=None):
    """Static optimisation over all frames: min sum v a^power + sum w rho^2 (+ c (N_m + N_l)^2, N in BW)."""
    N, nr, nm = R.shape
    nres, nx = len(RESERVED), nm + 5 + len(RESERVED)
    w = np.ones(nres) if reserve_weights is None else np.asarray(reserve_weights, float)
    Bn = np.zeros((N, nr, nx))
    Bn[:, :, :nm] = R * np.broadcast_to(np.asarray(F0, float), (N, nm))[:, None, :]   # per muscle or frame x muscle
    Bn[:, :, nm:nm + 5] = A.transpose(0, 2, 1) * scale
    Bn[:, :nres, nm + 5:] = np.eye(nres)
    n, i, j = np.nonzero(Bn)
    B = sp.csc_matrix((Bn[n, i, j] / scale, (n * nr + i, n * nx + j)), shape=(N * nr, N * nx))
    B = ca.DM(ca.Sparsity(B.shape[0], B.shape[1], B.indptr.tolist(), B.indices.tolist()), B.data)
    x = ca.SX.sym("x", nx)
    v = ca.DM(np.ones(nm) if activation_weights is None else np.asarray(activation_weights, float))
    f = ca.sum1(v * x[:nm] ** power) + ca.sum1(ca.DM(w) * x[nm + 5:] ** 2)
    f += contact_weight * ((x[nm] + x[nm + 1]) * scale / BW) ** 2
    X = ca.MX.sym("X", nx * N)
    S = ca.nlpsol("s", "ipopt", {"x": X, "f": ca.sum2(ca.Function("f", [x], [f]).map(N)(ca.reshape(X, nx, N))),
                                 "g": ca.mtimes(B, X) - ca.DM((Qc / scale).ravel())},
                  {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-8})
    lbx, ubx = np.full((nx, N), -np.inf), np.full((nx, N), np.inf)
    lbx[:nm], ubx[:nm], lbx[nm:nm + 2] = 0.0, 1.0, 0.0
    x0 = np.zeros((nx, N))
    x0[:nm] = 0.05
    sol = S(x0=x0.ravel("F"), lbx=lbx.ravel("F"), ubx=ubx.ravel("F"), lbg=0, ubg=0)
    if not S.stats()["success"]:
        raise RuntimeError(S.stats()["return_status"])
    Xs = np.asarray(sol["x"]).reshape(nx, N, order="F")
    return Xs[nm] * scale, Xs[nm + 1] * scale, Xs[nm + 5:].T


def passive_tensions(R, F0, Qpass):
    """C12: passive tensions p >= 0 (N, frames x muscles) along the muscles' paths that make the passive
    generalized forces ``Qpass`` (frames x the six primary rows): min sum (p/F0)^2 per frame, one QP."""
    from ocp_constraints.biomech.knee_static import _block_diagonal

    N, _, nm = R.shape
    nres = Qpass.shape[1]
    B = _block_diagonal(R[:, :nres, :] * F0[None, None, :] / 100.0)       # y = p / F0; rows in hN m
    Y = ca.MX.sym("Y", nm * N)
    S = ca.nlpsol("p", "ipopt", {"x": Y, "f": ca.sumsqr(Y), "g": ca.mtimes(B, Y) - ca.DM((Qpass / 100.0).ravel())},
                  {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-10,
                   "ipopt.hessian_constant": "yes", "ipopt.jac_c_constant": "yes", "ipopt.jac_d_constant": "yes",
                   "ipopt.mehrotra_algorithm": "yes", "ipopt.bound_relax_factor": 0.0})
    sol = S(x0=np.full(nm * N, 0.01), lbx=0.0, ubx=np.inf, lbg=0, ubg=0)
    if not S.stats()["success"]:
        raise RuntimeError("passive tensions: " + S.stats()["return_status"])
    return np.asarray(sol["x"]).reshape(N, nm) * F0[None, :]


def metrics(t, med, lat, res, meas) -> dict:
    tm, mm, ml = meas
    mm, ml = np.interp(t, tm, mm), np.interp(t, tm, ml)
    out = {}
    for k, y, m in (("medial", med, mm), ("lateral", lat, ml), ("total", med + lat, mm + ml)):
        out[k] = {"rmse_bw": float(np.sqrt(np.mean((y - m) ** 2)) / BW),
                  "r2": float(1 - np.sum((y - m) ** 2) / np.sum((m - m.mean()) ** 2)),
                  "peak_error_bw": float((y.max() - m.max()) / BW)}
    mid, late = (t > MID[0]) & (t < MID[1]), (t > LATE[0]) & (t < LATE[1])
    out["midstance_lateral_bw"] = [float(lat[mid].mean() / BW), float(ml[mid].mean() / BW)]
    out["late_total_peak_bw"] = [float((med + lat)[late].max() / BW), float((mm + ml)[late].max() / BW)]
    out["peak_reserves_Nm"] = dict(zip(RESERVED, np.abs(res).max(0).round(2).tolist()))
    return out


def opensim_arms(gait, muscles):
    """OpenSim's computeMomentArm of ``muscles`` about the 11 rows at the trial's frames (own process)."""
    import importlib.util

    if importlib.util.find_spec("opensim") is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        inp, out, code = Path(tmp) / "in.json", Path(tmp) / "out.json", Path(tmp) / "arms.py"
        inp.write_text(json.dumps({"P": gait.states["p"].tolist(), "names": gait.coordinate_names,
                                   "muscles": muscles, "rows": ROWS}))
        code.write_text(OPENSIM_ARMS)
        subprocess.run([sys.executable, str(code), str(MODEL), str(inp), str(out)], check=True, capture_output=True)
        return np.array(json.loads(out.read_text()))


def main(out_dir: Path):
    global BW
    clock = time.perf_counter()
    cycle = {}

    def select(plates, grf):
        cycle["t"] = gait_cycle(grf, [p for p, s in plates.items() if s == "right"])
        return cycle["t"]

    gait = run_inverse_dynamics(MODEL, TRIAL["IK"], TRIAL["GRF"], select=select)
    BW = sum(b.mass for b in gait.osim.bodies.values()) * float(np.linalg.norm(gait.osim.gravity))
    paths = MusclePaths()
    mus = paths.muscles
    F0 = np.array([muscle_parameters(MODEL, mus)[m].max_isometric_force for m in mus])
    Qc, R, A = frame_data(gait, paths, contact_matrix_function())
    meas = read_measured(TRIAL["KCF"])
    names, P = gait.coordinate_names, gait.states["p"]
    Mp = passive_hip_moment(P[:, names.index("hip_flexion")], P[:, names.index("knee_flexion")])
    Qp = Qc.copy()
    Qp[:, ROWS.index("hip_flexion")] -= Mp
    Q7 = Qc.copy()                      # C7: the paper's hip, knee and ankle passive moments together
    for c, m in passive_generalized_forces(HIP_KNEE_ANKLE, names, P).items():
        Q7[:, ROWS.index(c)] -= m
    params = muscle_parameters(MODEL, mus)
    volume = np.array([params[m].max_isometric_force * params[m].optimal_fiber_length for m in mus])
    volume /= volume.mean()             # C9: V_m ~ F0 l_opt (Happee & van der Helm 1995), mean weight 1
    from ocp_constraints.biomech.knee_hill import hill_forces, scale_lengths   # C11: Hill active force only
    from ocp_constraints.biomech.knee_static import muscle_kinematics

    Lmt, Vmt = muscle_kinematics(gait, paths)
    l_opt, l_s, alpha0 = (np.array([getattr(params[m], k) for m in mus]) for k in
                          ("optimal_fiber_length", "tendon_slack_length", "pennation_angle"))
    _, l_opt, l_s = scale_lengths(np.asarray(paths.unit_length(paths.q_vector({}))).ravel(), l_opt, l_s, alpha0)
    hill_active = hill_forces(Lmt, Vmt, F0, l_opt, l_s, alpha0).active
    Qpass = Qc[:, :len(RESERVED)] - Q7[:, :len(RESERVED)]         # C12: C7's passive generalized forces
    Ptens = passive_tensions(R, F0, Qpass)
    Q12 = Qc - np.einsum("ncm,nm->nc", R, Ptens)
    assert np.abs(Q12[:, :len(RESERVED)] - Q7[:, :len(RESERVED)]).max() < 1e-6
    print("C12 passive tensions: largest p/F0 %.3f, largest %s %.0f N; knee locked rows changed by up to %s" % (
        (Ptens / F0).max(), mus[int(np.argmax(Ptens.max(0)))], Ptens.max(),
        np.abs(Q12 - Q7)[:, len(RESERVED):].max(0).round(1).tolist()), flush=True)
    cheap_hip = np.ones(len(RESERVED))
    cheap_hip[:3] = 1e-3
    rows = [("C0", "baseline: ideal muscles, sum a^2, reserves 1 N m^-2, no passive hip moment", {}),
            ("C1", "objective sum a^3 (Crowninshield & Brand 1981)", {"power": 3}),
            ("C2a", "objective + contact-load term 0.1 (N_total/BW)^2 (as MocoJointReactionGoal)",
             {"contact_weight": 0.1}),
            ("C2b", "objective + contact-load term 1 (N_total/BW)^2", {"contact_weight": 1.0}),
            ("C4", "diagnostic, not a model: hip reserves 1000x cheaper", {"reserve_weights": cheap_hip}),
            ("C5", "passive hip flexion moment, Riener & Edrich 1999 (first round's model)", {"Q": Qp}),
            ("C7", "passive hip, knee and ankle moments, Riener & Edrich 1999 (preregistered, adopted in round 2)",
             {"Q": Q7}),
            ("C9", "C7 with volume-weighted effort sum V a^2, Happee & van der Helm 1995 (reported only)",
             {"Q": Q7, "activation_weights": volume}),
            ("C11", "C7 with Hill active force-length-velocity (rigid tendon), no fibre passive force (reported only)",
             {"Q": Q7, "F0": hill_active}),
            ("C12", "C7's passive moments as passive tension along the muscles' paths (reported only)", {"Q": Q12}),
            ("C13", "C7 with the vasti pulling the tibia along the patellar ligament's line on the locked knee "
                    "directions (preregistered, adopted)", {"Q": Q7, "R": patellar_ligament_arms(R, mus)})]
    arms = opensim_arms(gait, mus)
    if arms is not None:
        Rg, Ra = R.copy(), R.copy()
        for m in ("gasmed", "gaslat"):
            Rg[:, :, mus.index(m)] = arms[:, :, mus.index(m)]
        rows += [("C3a", "gastrocnemii: moment arms by OpenSim's computeMomentArm, not -dL/dq of the fitted length",
                  {"R": Rg}),
                 ("C3b", "every muscle: moment arms by OpenSim's computeMomentArm", {"R": arms}),
                 ("C3a+C5", "gastrocnemius moment arms of C3a with the passive hip moment of C5", {"R": Rg, "Q": Qp}),
                 ("C10", "C7 with the gastrocnemius moment arms of C3a (reported only)", {"R": Rg, "Q": Q7})]
        err = np.abs(arms - R).max(axis=0)                     # rows x muscles
        worst = {c: {mus[k]: float(err[j, k]) for k in np.argsort(-err[j])[:3]} for j, c in enumerate(ROWS)}
    else:
        worst = None
    results = {}
    for key, text, opt in rows:
        opt = dict(opt)
        q, r_, f0 = opt.pop("Q", Qc), opt.pop("R", R), opt.pop("F0", F0)
        med, lat, res = solve(q, r_, A, f0, **opt)
        results[key] = {"change": text, **metrics(gait.t, med, lat, res, meas)}
        print(key, json.dumps({k: v for k, v in results[key].items() if k != "change"})[:200], flush=True)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "candidates.json").write_text(json.dumps({"trial": "ngait_og5", "body_weight_N": BW,
                                                         "results": results, "moment_arm_error_m": worst,
                                                         "passive_hip_range_Nm": [float(Mp.min()), float(Mp.max())],
                                                         "wall_s": time.perf_counter() - clock}, indent=1))
    lines = ["| | change | medial RMSE / R^2 / peak err | lateral RMSE / R^2 / peak err | total RMSE / R^2 / peak err "
             "| mid-stance lateral (meas.) | late total peak (meas.) |", "|---|---|---|---|---|---|---|"]
    for key, v in results.items():
        cells = " | ".join(f"{v[k]['rmse_bw']:.2f} / {v[k]['r2']:.2f} / {v[k]['peak_error_bw']:+.2f}"
                           for k in ("medial", "lateral", "total"))
        lines.append(f"| {key} | {v['change']} | {cells} | {v['midstance_lateral_bw'][0]:.2f} "
                     f"({v['midstance_lateral_bw'][1]:.2f}) | {v['late_total_peak_bw'][0]:.2f} "
                     f"({v['late_total_peak_bw'][1]:.2f}) |")
    (out_dir / "candidates.md").write_text("ngait_og5, BW = %.1f N, RMSE and peak error in BW "
                                           "(`python scripts/knee_candidates.py`)\n\n" % BW + "\n".join(lines) + "\n")
    print("\n".join(lines))


def contact_points_on_mesh(out_dir: Path) -> dict:
    """C6: where each femoral condyle touches its plateau on the implant mesh itself, 0-60 degrees of flexion.

    The femoral-component mesh (``femPoints_188.csv``, femoral frame) is placed by the JW knee
    (``R_FM = Rz(flexion)``, ``p_FM = (0, knee_ty, 0)``, tray frame, +Z medial); the contact
    vertex of a condyle is its lowest one (smallest tray Y, towards the plateau). Written to
    ``contact_geometry.json`` beside the sphere model's centres (``medial_cz``, ``lateral_cz``)."""
    from ocp_constraints.biomech.knee_contact import stored_geometry

    pts = np.loadtxt(J / "workshop_bcn2024" / "ExperimentalData" / "femPoints_188.csv", delimiter=",")
    geo = stored_geometry()
    rows = []
    for deg in range(0, -61, -5):
        a = np.radians(deg)
        Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        X = pts @ Rz.T + np.array([0.0, 0.042, 0.0])
        row = {"knee_flexion_deg": deg}
        for side, sign in (("medial", 1.0), ("lateral", -1.0)):
            V = X[X[:, 2] * sign > 0]
            row[f"{side}_z_mm"] = float(1000 * V[np.argmin(V[:, 1]), 2])
        rows.append(row)
    out = {"mesh_contact_points": rows,
           "sphere_model_z_mm": {"medial": 1000 * geo["medial_cz"], "lateral": 1000 * geo["lateral_cz"]},
           "mesh_spacing_mm_mean": float(np.mean([r["medial_z_mm"] - r["lateral_z_mm"] for r in rows])),
           "sphere_spacing_mm": 1000 * (geo["medial_cz"] - geo["lateral_cz"])}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "contact_geometry.json").write_text(json.dumps(out, indent=1))
    return out


def plot_before_after(out_dir: Path) -> Path:
    """``before_after.png``: medial, lateral, total of ``<out>/before/loads.csv`` (issue 14's model, C0, static),
    ``<out>/static/loads.csv`` (C13, static) and ``<out>/loads.csv`` (the default: C13 with activation dynamics)
    against the measured loads."""
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def load(folder):
        rows = list(csv.DictReader(open(folder / "loads.csv")))
        return (np.array([float(r["t"]) for r in rows]),
                *(np.array([float(r[c]) for r in rows]) for c in ("N_medial", "N_lateral")))

    tm, mm, ml = read_measured(TRIAL["KCF"])
    runs = {"before (C0, static)": load(out_dir / "before"), "C13, static": load(out_dir / "static"),
            "C13 with activation dynamics (default)": load(out_dir)}
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for ax, k in zip(axes, ("medial", "lateral", "total")):
        for (label, (t, m, l)), style in zip(runs.items(), (":", "-.", "-")):
            y = {"medial": m, "lateral": l, "total": m + l}[k]
            ax.plot(t, y / BW, style, label=label)
        keep = (tm >= t[0]) & (tm <= t[-1])
        ax.plot(tm[keep], {"medial": mm, "lateral": ml, "total": mm + ml}[k][keep] / BW, "k--", label="measured (eTibia)")
        ax.set(ylabel=f"{k} [BW]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set(title="ngait_og5: knee contact loads")
    axes[-1].set(xlabel="t [s]")
    path = out_dir / "before_after.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


BW = 614.25
if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "results" / "knee"))
    ap.add_argument("--plot-only", action="store_true", help="only before_after.png from the two runs' loads.csv")
    args = ap.parse_args()
    if not args.plot_only:
        main(Path(args.out))
    geo = contact_points_on_mesh(Path(args.out))
    print(f"C6 contact points on the mesh: spacing {geo['mesh_spacing_mm_mean']:.1f} mm (mean over 0-60 deg), "
          f"medial {min(r['medial_z_mm'] for r in geo['mesh_contact_points']):.1f}-"
          f"{max(r['medial_z_mm'] for r in geo['mesh_contact_points']):.1f} mm, lateral "
          f"{min(r['lateral_z_mm'] for r in geo['mesh_contact_points']):.1f}-"
          f"{max(r['lateral_z_mm'] for r in geo['mesh_contact_points']):.1f} mm; spheres "
          f"{geo['sphere_spacing_mm']:.1f} mm")
    print(plot_before_after(Path(args.out)))
