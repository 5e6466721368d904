"""Issue 15: why the static optimisation co-contracts the semimembranosus and the vasti in loading response.

    python scripts/knee_hip_balance_diagnostic.py --data R/ExampleTrackingSimulations/OpenSimModel/subject_GC \
        [--out results/knee]

A diagnostic, not a model: nothing here is adopted. Two pieces of evidence, written to
``<out>/hip_balance_diagnostic.md``:

1. Shadow prices at ngait_og5's loading-response peak (2.38 s), default model (C13). For a row ``c`` with a
   reserve ``rho_c`` at cost ``w rho_c^2``, the optimality condition gives the price of one more N m of that
   balance, ``mu_c = 2 w rho_c``. A muscle that crosses only the hip is worth activating iff
   ``F0 sum_c mu_c r_c > 0`` (then ``2 a = F0 sum_c mu_c r_c``). The table lists that value for the hip
   extensors, split by row, with the muscles' moment arms and ``F0`` (both the model file's: the moment arms
   agree with OpenSim's along the path to 0.1-4.3 mm, ``moment_arm_audit.md``).
2. One balance at a time made nearly free (its reserve 1000x cheaper), on the three trials: which balance
   forces the co-contraction. (A reserve of 20 N m is no model; this shows where the model is stiff.)
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))
import knee_candidates as kc  # noqa: E402
import ocp_constraints.biomech.knee_pipeline as kp  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED  # noqa: E402

MODEL = kc.MODEL
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")
HIP = ["hip_flexion", "hip_adduction", "hip_rotation"]
EXTENSORS = ["glmax1", "glmax2", "glmax3", "addmagIsch", "addmagDist", "semimem", "semiten", "bflh", "glmed1",
             "glmed2", "glmed3"]


def trial_inputs(folder: Path, trial: str) -> dict:
    """The default ``knee`` run of a trial, with the static problem's inputs (Q, R, A, F0) captured."""
    cap, orig = {}, kp.solve_static

    def grab(t, Qc, R, A, F0, **kw):
        cap.update(t=t, Qc=Qc, R=R, A=A, F0=F0)
        return orig(t, Qc, R, A, F0, **kw)

    kp.solve_static = grab
    try:
        run = kp.run_knee(MODEL, *[folder / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")], method="static")
    finally:
        kp.solve_static = orig
    return {**cap, "run": run}


def shadow_prices(inp: dict, at: float) -> list[str]:
    run, res = inp["run"], inp["run"]["result"]
    k = int(np.argmin(np.abs(res.t - at)))
    mu = 2.0 * res.reserve[k, :3]                  # RESERVE_WEIGHT = 1 per (N m)^2
    lines = [f"Frame {res.t[k]:.3f} s: the muscles' share of the balance (Q less the passive moments, N m) " + ", ".join(
        f"{c} {inp['Qc'][k, j]:+.1f}" for j, c in enumerate(HIP)) + "; reserves " + ", ".join(
        f"{res.reserve[k, j]:+.2f}" for j in range(3)) + " N m; prices mu = 2 rho: " + ", ".join(
        f"{c} {mu[j]:+.2f}" for j, c in enumerate(HIP)) + " per N m.", "",
        "| muscle | F0 (N) | arms flexion / adduction / rotation (mm) | F0 mu_c r_c: flexion / adduction / rotation "
        "| sum | activation |", "|---|---|---|---|---|---|"]
    for m in EXTENSORS:
        i = res.muscles.index(m)
        r = inp["R"][k, :3, i]
        parts = inp["F0"][i] * mu * r
        lines.append(f"| {m} | {inp['F0'][i]:.0f} | {' / '.join(f'{1000 * v:+.1f}' for v in r)} | "
                     f"{' / '.join(f'{v:+.2f}' for v in parts)} | {parts.sum():+.2f} | {res.activation[k, i]:.2f} |")
    return lines


def relaxed(inp: dict) -> list[str]:
    kc.BW = inp["run"]["bw"]        # the candidates' solver reads it (contact-load term, unused here)
    meas = inp["run"]["measured"]
    out = []
    for name, j in [("none (C13)", None)] + [(f"{c} reserve 1000x cheaper", RESERVED.index(c)) for c in HIP]:
        w = np.ones(len(RESERVED))
        if j is not None:
            w[j] = 1e-3
        med, lat, res = kc.solve(inp["Qc"], inp["R"], inp["A"], inp["F0"], reserve_weights=w)
        m = kp.compare(inp["t"], {"medial": med, "lateral": lat, "total": med + lat}, meas, inp["run"]["bw"])
        out.append(f"{name} | " + " | ".join(f"{m[s]['rmse_bw']:.2f} / {m[s]['peak_error_bw']:+.2f}"
                                             for s in ("medial", "lateral", "total"))
                   + " | " + " / ".join(f"{v:.1f}" for v in np.abs(res[:, :3]).max(0)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="ReducePoly_forMSK .../OpenSimModel/subject_GC")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    args = ap.parse_args()
    clock, cpu = time.perf_counter(), time.process_time()
    lines = ["# Why the static optimisation co-contracts in loading response (diagnostic, nothing adopted)", "",
             "`python scripts/knee_hip_balance_diagnostic.py --data ...`; default model (C13, static).", "",
             "## Shadow prices at ngait_og5's loading-response peak", ""]
    rows = ["", "## One hip balance at a time made nearly free", "",
            "| trial | relaxed balance | medial RMSE / peak error (BW) | lateral | total | peak hip reserves "
            "flexion / adduction / rotation (N m) |", "|---|---|---|---|---|---|"]
    for trial in TRIALS:
        folder = kc.J / "reducepoly_subject_GC" if trial == "ngait_og5" else args.data
        inp = trial_inputs(folder, trial)
        if trial == "ngait_og5":
            lines += shadow_prices(inp, 2.38)
        rows += [f"| {trial} | {r} |" for r in relaxed(inp)]
    text = "\n".join(lines + rows) + "\n"
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "hip_balance_diagnostic.md").write_text(text)
    print(text)
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
