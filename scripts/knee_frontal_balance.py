"""Issue 15: where the knee's frontal-plane (adduction) and axial balances come from, along the gait cycle.

    python scripts/knee_frontal_balance.py [--out results/knee] [--passive MODEL] [--tag NAME]

Runs ``knee`` on ngait_og5 (static optimisation, the given passive model, default the adopted one) and
decomposes two rows of the balance the optimiser meets (paper eqs. 35-41, :mod:`ocp_constraints.biomech.knee_static`)

    Q_c = sum_m r_mc F_m + sum_j lambda_j A_jc (+ reserve + passive on the primary rows)

* ``knee_adduction`` (the locked frontal direction, N m): ``Q`` from the inverse dynamics is the moment the
  joint must supply against the ground reaction, gravity and inertia of the shank and foot ("external");
  the muscles' part (with the five largest contributors), the medial and lateral condyle forces' part,
  the shear / rotation multipliers' part. There is no passive moment (Riener & Edrich measured the
  sagittal plane only) and no reserve on a locked direction.
* ``knee_ty`` (along the tray axis, N): the total contact force is the external axial load (``Q_ty``,
  the condyle forces' axial shares are 1) plus the muscles' compression ``-r_ty F``; per muscle.

Then, as a diagnosis (not a model): with the *measured* medial and lateral forces put in place of the
predicted ones, the frontal moment the non-contact structures (muscles, ligaments) would have to supply,
``Q_add - A_med N_med,meas - A_lat N_lat,meas - (other multipliers)``, against what the model's muscles
supply. Writes ``frontal_balance{tag}.csv``, ``.md`` and ``.png`` in ``--out``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_model import contact_matrix_function, default_parameters  # noqa: E402
from ocp_constraints.biomech.knee_muscles import SECONDARY, MusclePaths  # noqa: E402
from ocp_constraints.biomech.knee_options import PASSIVE_DEFAULT, PASSIVE_HIP, QUADRICEPS, QUADRICEPS_DEFAULT  # noqa: E402,E501
from ocp_constraints.biomech.knee_pipeline import run_knee  # noqa: E402
from ocp_constraints.biomech.knee_quadriceps import patellar_ligament_arms  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED, frame_data  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIAL = {k: J / "reducepoly_subject_GC" / k / f"{k}_ngait_og5.mat" for k in ("IK", "GRF", "KCF")}
ROWS = RESERVED + SECONDARY
ADD, TY = ROWS.index("knee_adduction"), ROWS.index("knee_ty")
WINDOWS = {"loading response peak": (2.25, 2.40), "mid-stance": (2.43, 2.60), "terminal stance": (2.65, 2.85),
           "swing": (2.95, 3.25)}


def decompose(run: dict) -> dict:
    """Per frame: the frontal and axial balances split into their parts (module docstring)."""
    g, r = run["gait"], run["result"]
    geometry = {**default_parameters(), **run["model_data"].geometry}     # as run_knee (no overrides here)
    paths = MusclePaths(run["model_data"].muscle_paths)
    Qc, R, A = frame_data(g, paths, contact_matrix_function(geometry))
    if run.get("quadriceps") == "patellar-ligament":
        R = patellar_ligament_arms(R, paths.muscles)
    tm, mm, ml = run["measured"]
    med_m, lat_m = np.interp(r.t, tm, mm), np.interp(r.t, tm, ml)
    per_muscle_add = R[:, ADD, :] * r.force                # N m, frames x muscles
    per_muscle_ty = -R[:, TY, :] * r.force                 # N of compression (the contact carries -R_ty F)
    out = {"t": r.t, "Q_add": Qc[:, ADD], "muscle_add": per_muscle_add.sum(1),
           "medial_add": A[:, 0, ADD] * r.medial, "lateral_add": A[:, 1, ADD] * r.lateral,
           "other_multipliers_add": np.einsum("nj,nj->n", A[:, 2:, ADD], r.lam[:, 2:]),
           "lever_medial_m": A[:, 0, ADD], "lever_lateral_m": A[:, 1, ADD],
           "N_medial": r.medial, "N_lateral": r.lateral, "N_medial_measured": med_m, "N_lateral_measured": lat_m,
           "Q_ty": Qc[:, TY], "muscle_compression": per_muscle_ty.sum(1),
           "axial_share_medial": A[:, 0, TY], "axial_share_lateral": A[:, 1, TY],
           "per_muscle_add": per_muscle_add, "per_muscle_ty": per_muscle_ty, "muscles": r.muscles}
    # what the non-contact structures would have to give for the measured split (diagnosis only)
    out["needed_noncontact_add"] = (Qc[:, ADD] - A[:, 0, ADD] * med_m - A[:, 1, ADD] * lat_m
                                    - out["other_multipliers_add"])
    # the split the model's own frontal moments give at the *measured* total: how much of the lateral
    # deficit is the total (compression), how much the frontal moment
    lm, ll = A[:, 0, ADD], A[:, 1, ADD]
    rest = Qc[:, ADD] - out["muscle_add"] - out["other_multipliers_add"]
    out["N_lateral_at_measured_total"] = (rest - lm * (med_m + lat_m)) / (ll - lm)
    out["residual_add"] = (out["muscle_add"] + out["medial_add"] + out["lateral_add"] + out["other_multipliers_add"]
                           - Qc[:, ADD])
    return out


def _mean(d, key, w):
    t = d["t"]
    keep = (t >= w[0]) & (t <= w[1])
    return float(np.mean(d[key][keep]))


def table(d: dict, bw: float) -> str:
    lines = ["| window (s) | Q_add: external (N m) | muscles (N m) | medial contact (N m) | lateral contact (N m) | "
             "shear/rotation multipliers (N m) | lever medial / lateral (mm) | N medial / lateral, model (BW) | "
             "N medial / lateral, measured (BW) | non-contact moment the measured split needs (N m) | "
             "muscle compression (BW) | external axial (BW) | lateral with the model's frontal moments at the measured total (BW) |",
             "|---|" + "---|" * 12]
    for name, w in WINDOWS.items():
        f = lambda k: _mean(d, k, w)  # noqa: E731
        lines.append(f"| {name} {w[0]:.2f}-{w[1]:.2f} | {f('Q_add'):+.1f} | {f('muscle_add'):+.1f} | "
                     f"{f('medial_add'):+.1f} | {f('lateral_add'):+.1f} | {f('other_multipliers_add'):+.1f} | "
                     f"{1e3 * f('lever_medial_m'):+.1f} / {1e3 * f('lever_lateral_m'):+.1f} | "
                     f"{f('N_medial') / bw:.2f} / {f('N_lateral') / bw:.2f} | "
                     f"{f('N_medial_measured') / bw:.2f} / {f('N_lateral_measured') / bw:.2f} | "
                     f"{f('needed_noncontact_add'):+.1f} | {f('muscle_compression') / bw:.2f} | "
                     f"{f('Q_ty') / bw:.2f} | {f('N_lateral_at_measured_total') / bw:.2f} |")
    return "\n".join(lines)


def top_muscles(d: dict, key: str, w, n: int = 6, unit: str = "N m") -> str:
    t = d["t"]
    keep = (t >= w[0]) & (t <= w[1])
    m = d[key][keep].mean(0)
    order = np.argsort(-np.abs(m))[:n]
    return ", ".join(f"{d['muscles'][i]} {m[i]:+.1f} {unit}" for i in order)


def plot(d: dict, bw: float, path: Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = d["t"]
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    ax[0].plot(t, d["Q_add"], "k", lw=2, label="Q knee_adduction (external + inertia)")
    ax[0].plot(t, d["muscle_add"], label="muscles (model)")
    ax[0].plot(t, d["medial_add"], label="medial contact (model)")
    ax[0].plot(t, d["lateral_add"], label="lateral contact (model)")
    ax[0].plot(t, d["other_multipliers_add"], ":", label="shear / rotation multipliers")
    ax[0].plot(t, d["needed_noncontact_add"], "r--", label="non-contact moment the measured split needs")
    ax[0].set_ylabel("N m")
    ax[0].legend(fontsize=7, ncol=2)
    ax[0].set_title(title, fontsize=9)
    ax[1].plot(t, d["N_medial"] / bw, "C1", label="medial, model")
    ax[1].plot(t, d["N_medial_measured"] / bw, "C1--", label="medial, measured")
    ax[1].plot(t, d["N_lateral"] / bw, "C2", label="lateral, model")
    ax[1].plot(t, d["N_lateral_measured"] / bw, "C2--", label="lateral, measured")
    ax[1].set_ylabel("contact force (BW)")
    ax[1].legend(fontsize=7, ncol=2)
    ax[2].plot(t, d["Q_ty"] / bw, "k", label="external axial load (Q along the tray axis)")
    ax[2].plot(t, d["muscle_compression"] / bw, label="muscle compression")
    ax[2].plot(t, (d["N_medial"] + d["N_lateral"]) / bw, label="total, model")
    ax[2].plot(t, (d["N_medial_measured"] + d["N_lateral_measured"]) / bw, "--", label="total, measured")
    ax[2].set_ylabel("BW")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(fontsize=7, ncol=2)
    for a in ax:
        for w in WINDOWS.values():
            a.axvspan(*w, color="0.93", zorder=0)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    ap.add_argument("--passive", choices=PASSIVE_HIP, default=PASSIVE_DEFAULT)
    ap.add_argument("--quadriceps", choices=QUADRICEPS, default=QUADRICEPS_DEFAULT)
    ap.add_argument("--tag", default="", help="suffix of the output files")
    args = ap.parse_args()
    clock, cpu = time.perf_counter(), time.process_time()
    run = run_knee(MODEL, TRIAL["IK"], TRIAL["GRF"], TRIAL["KCF"], passive_hip=args.passive,
                   quadriceps=args.quadriceps, method="static")
    d = decompose(run)
    bw = run["bw"]
    assert np.abs(d["residual_add"]).max() < 1e-3, d["residual_add"]       # the parts add up to Q
    stem = args.out / f"frontal_balance{args.tag}"
    cols = [k for k, v in d.items() if isinstance(v, np.ndarray) and v.ndim == 1]
    np.savetxt(stem.with_suffix(".csv"), np.column_stack([d[k] for k in cols]), delimiter=",",
               header=",".join(cols), comments="", fmt="%.6g")
    title = f"ngait_og5, passive model {args.passive}, quadriceps {args.quadriceps}, static optimisation"
    plot(d, bw, stem.with_suffix(".png"), title)
    text = [f"# Frontal-plane and axial balance of the knee ({title})", "",
            "`python scripts/knee_frontal_balance.py" + (f" --passive {args.passive} --quadriceps {args.quadriceps} "
                                                         f"--tag {args.tag}" if args.tag else "")
            + "`; means over each window; BW = %.1f N. Signs: generalized forces on the JW `knee_adduction` "
            "coordinate (the parts add up to Q to %.1e N m). The lever arms are `A_add` of each condyle force "
            "(m per N: the condyle's frontal lever about the adduction axis)." % (bw, np.abs(d["residual_add"]).max()),
            "", table(d, bw), ""]
    for name, w in WINDOWS.items():
        text.append(f"- {name}: frontal moment by muscle: {top_muscles(d, 'per_muscle_add', w)}; "
                    f"compression by muscle: {top_muscles(d, 'per_muscle_ty', w, unit='N')}")
    stem.with_suffix(".md").write_text("\n".join(text) + "\n")
    print("\n".join(text))
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
