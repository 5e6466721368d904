"""Issue 15, diagnostics D1-D4: which of Riener & Edrich's passive terms replaces which muscle.

    python scripts/knee_passive_terms.py [--out results/knee]

Runs the inverse dynamics of ngait_og5 once and the static optimisation of the default model (C13:
Riener & Edrich 1999 hip, knee and ankle moments, quadriceps through the patellar ligament) with one
passive term removed at a time (``results/knee/preregistration.md``, D1-D4): the knee equation's extension
stop ``exp(2.220 - 0.150 K)`` (D1), the whole knee equation (D2), the ankle equation (D3), the hip
equation (D4); and C14, the stop as posterior-capsule tension ``M_stop / rho`` (rho the implant's condyle
radius) pressing the tibia along the tray axis. Diagnostics and a reported-only candidate: nothing here is adopted. Writes ``passive_terms.md``: RMSE (BW)
per compartment, the windows' mean loads against the measured ones, and the knee-crossing muscles'
mean forces in terminal stance. The measured loads are used for the table only.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.gait import run_inverse_dynamics  # noqa: E402
from ocp_constraints.biomech.knee_contact import stored_geometry  # noqa: E402
from ocp_constraints.biomech.knee_model import contact_matrix_function  # noqa: E402
from ocp_constraints.biomech.knee_muscles import SECONDARY, MusclePaths, muscle_parameters  # noqa: E402
from ocp_constraints.biomech.knee_passive import HIP_KNEE_ANKLE, passive_generalized_forces  # noqa: E402
from ocp_constraints.biomech.knee_pipeline import compare, gait_cycle, read_measured  # noqa: E402
from ocp_constraints.biomech.knee_quadriceps import patellar_ligament_arms  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED, frame_data, solve_static  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIAL = {k: J / "reducepoly_subject_GC" / k / f"{k}_ngait_og5.mat" for k in ("IK", "GRF", "KCF")}
WINDOWS = {"loading response": (2.25, 2.40), "mid-stance": (2.43, 2.60), "terminal stance": (2.65, 2.85)}
SHOWN = ("gasmed", "gaslat", "soleus", "bfsh", "bflh", "semimem", "vaslat", "tfl", "recfem", "iliacus")


def main(out: Path) -> None:
    clock, cpu = time.perf_counter(), time.process_time()
    gait = run_inverse_dynamics(MODEL, TRIAL["IK"], TRIAL["GRF"],
                                select=lambda plates, grf: gait_cycle(grf, [p for p, s in plates.items() if s == "right"]))
    bw = sum(b.mass for b in gait.osim.bodies.values()) * float(np.linalg.norm(gait.osim.gravity))
    paths = MusclePaths()
    mus = paths.muscles
    F0 = np.array([muscle_parameters(MODEL, mus)[m].max_isometric_force for m in mus])
    Qc, R, A = frame_data(gait, paths, contact_matrix_function())
    R = patellar_ligament_arms(R, mus)
    names, P = gait.coordinate_names, gait.states["p"]
    full = passive_generalized_forces(HIP_KNEE_ANKLE, names, P)
    K = -np.degrees(P[:, names.index("knee_flexion")])
    stop = -np.exp(2.220 - 0.150 * K)           # the extension stop's generalized force on knee_flexion
    variants = {"C13 (all terms)": full,
                "D1 without the knee's extension stop": {**full, "knee_flexion": full["knee_flexion"] - stop},
                "D2 without the knee equation": {c: m for c, m in full.items() if c != "knee_flexion"},
                "D3 without the ankle equation": {c: m for c, m in full.items() if c != "ankle_angle"},
                "D4 without the hip equation": {c: m for c, m in full.items() if c != "hip_flexion"}}
    tm, mm, ml = read_measured(TRIAL["KCF"])
    med_m, lat_m = np.interp(gait.t, tm, mm), np.interp(gait.t, tm, ml)
    head = ("| variant | medial; lateral; total: RMSE (BW) / R^2 / peak error (BW) | " + " | ".join(
        f"{w} medial / lateral / total (BW)" for w in WINDOWS) + " | late total peak (BW) | peak reserve (N m) | terminal stance mean force (N): "
        + ", ".join(SHOWN) + " |")
    lines = [head, "|---" * (5 + len(WINDOWS)) + "|"]
    row = ["measured", ""]
    for a, b in WINDOWS.values():
        k = (gait.t >= a) & (gait.t <= b)
        row.append(f"{med_m[k].mean() / bw:.2f} / {lat_m[k].mean() / bw:.2f} / {(med_m + lat_m)[k].mean() / bw:.2f}")
    late = (gait.t >= 2.65) & (gait.t <= 2.85)
    lines.append("| " + " | ".join(row + [f"{(med_m + lat_m)[late].max() / bw:.2f}", "", ""]) + " |")
    # C14: the stop as posterior-capsule tension at the condyle radius: T = M_stop / rho along the tray axis
    rho = 0.5 * sum(stored_geometry()[f"{s}_radius"] for s in ("medial", "lateral"))
    capsule = np.exp(2.220 - 0.150 * K) / rho
    variants["C14 stop as capsule tension at the condyle radius (reported only)"] = full
    for name, moments in variants.items():
        Q = Qc.copy()
        for c, m in moments.items():
            Q[:, RESERVED.index(c)] -= m
        if name.startswith("C14"):      # its generalized force on knee_ty is -T: the muscles' share is Q + T
            Q[:, len(RESERVED) + SECONDARY.index("knee_ty")] += capsule
        r = solve_static(gait.t, Q, R, A, F0)
        cmp = compare(r.t, {"medial": r.medial, "lateral": r.lateral, "total": r.total}, (tm, mm, ml), bw)
        cells = [name, "; ".join(f"{cmp[k]['rmse_bw']:.2f} / {cmp[k]['r2']:.2f} / {cmp[k]['peak_error_bw']:+.2f}"
                                 for k in ("medial", "lateral", "total"))]
        for a, b in WINDOWS.values():
            k = (r.t >= a) & (r.t <= b)
            cells.append(f"{r.medial[k].mean() / bw:.2f} / {r.lateral[k].mean() / bw:.2f} / {r.total[k].mean() / bw:.2f}")
        late = (r.t >= 2.65) & (r.t <= 2.85)
        cells.append(f"{r.total[late].max() / bw:.2f}")
        cells.append(f"{np.abs(r.reserve).max():.1f}")
        a, b = WINDOWS["terminal stance"]
        k = (r.t >= a) & (r.t <= b)
        cells.append(", ".join(f"{r.force[k, mus.index(m)].mean():.0f}" for m in SHOWN))
        lines.append("| " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    text = ("# Riener & Edrich's passive terms one at a time (diagnostics D1-D4, C14; ngait_og5, static, C13)\n\n"
            f"`python scripts/knee_passive_terms.py`; BW = {bw:.1f} N; windows' means. Not models: "
            "`preregistration.md`.\n\n" + "\n".join(lines) + "\n")
    out.mkdir(parents=True, exist_ok=True)
    (out / "passive_terms.md").write_text(text)
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    main(ap.parse_args().out)
