"""Issue 15, candidate C19: hip reserves weighted by the hip-joint-centre error propagated through the ID.

    python scripts/knee_c19_hjc_sigma.py --data R/ExampleTrackingSimulations/OpenSimModel/subject_GC [--out results/knee]

Preregistered in ``results/knee/preregistration.md`` (seventh round, commit a49e87c, before any C19 load was
computed). Per trial (ngait_og5 from the shared data, bouncy7 and mtpgait3 from ``--data``): the default ``knee`` run's
inputs (inverse dynamics once, the default model C13), then

- the default (uniform reserve weight 1) and C19 (``s = 9.3 mm``, Bell et al. 1989) under the default method
  (collocation, which decides) and under static optimisation (reported);
- the reported-only ``s`` of the preregistration (7.7, 11.8, 15.7 mm) under collocation.

C19's weights: ``w_c(t) = 1 / (2 (sigma_c(t)^2 + sigma_0^2))`` on the three hip rows, ``sigma_c = s |e_c x F_hip|``
(:mod:`ocp_constraints.biomech.knee_id_uncertainty`), ``sigma_0 = 1/sqrt(2)`` N m; other rows ``w = 1``. Writes
``<out>/c19_hjc_sigma.md`` and ``.json`` (RMSE / R^2 / peak error per compartment beside the default's, peak
``|rho_c| / sigma_c`` and frames over 2 sigma per hip direction, the other reserves' peaks, sigma's range, the
semimembranosus and vasti peaks, the rule's conditions) and ``c19_hjc_sigma.png``. Prints wall and CPU time.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import ocp_constraints.biomech.knee_pipeline as kp  # noqa: E402
from ocp_constraints.biomech.knee_collocation import solve_collocation, solve_collocation_or_static  # noqa: E402
from ocp_constraints.biomech.knee_id_uncertainty import (HIP_ROWS, S_BELL_1989, S_DAVIS, S_HARRINGTON,  # noqa: E402
                                                         S_TYLKOWSKI, SIGMA_0, hjc_sigma, reserve_weights_per_frame)
from ocp_constraints.biomech.knee_static import RESERVED, solve_static  # noqa: E402
from ocp_constraints.errors import KneeError  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")
SENSITIVITY = {"Harrington (Mantovani 2016), s = 7.7 mm": S_HARRINGTON, "Tylkowski (Bell 1989), s = 11.8 mm": S_TYLKOWSKI,
               "Davis (Mantovani 2016), s = 15.7 mm": S_DAVIS}
VASTI = ("vasint", "vaslat", "vasmed")


def inputs(folder: Path, trial: str) -> dict:
    """The default ``knee`` run of a trial (static), with the arguments its solver was called with."""
    seen = {}

    def capture(t, Qc, R, A, F0, **kw):
        seen.update(args=(t, Qc, R, A, F0), kw=kw)
        return solve_static(t, Qc, R, A, F0, **kw)

    files = [folder / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")]
    kp.solve_static = capture
    try:
        run = kp.run_knee(MODEL, *files, method="static")
    finally:
        kp.solve_static = solve_static
    run.update(seen)
    return run


def solve(run: dict, method: str, weights) -> tuple[object, float, float]:
    """One solve on the run's inputs; ``weights`` None is the default (the pipeline's own call)."""
    clock, cpu = time.perf_counter(), time.process_time()
    args, kw = run["args"], dict(run["kw"])
    try:
        if method == "static":
            res = solve_static(*args, **kw) if weights is None else solve_static(*args, reserve_weight=weights, **kw)
        elif weights is None:
            res = solve_collocation_or_static(*args, **kw)
        else:
            res = solve_collocation(*args, reserve_weight=weights, **kw)
    except KneeError as exc:
        res = exc
    return res, time.perf_counter() - clock, time.process_time() - cpu


def row(run: dict, res, sigma: np.ndarray, muscles: list[str]) -> dict:
    """The table's numbers for one solve; ``sigma`` the combined sigma_c (frames x 3) for the ratios."""
    if isinstance(res, Exception) or getattr(res, "fallback", None):
        return {"solved": False, "message": str(res if isinstance(res, Exception) else res.fallback)}
    res.muscles = muscles
    c = kp.compare(res.t, {"medial": res.medial, "lateral": res.lateral, "total": res.total}, run["measured"], run["bw"])
    rho = res.reserve[:, :3]
    ratio = np.abs(rho) / sigma
    f = dict(zip(muscles, res.force.T))
    return {"solved": True, "comparison": c, "peak_ratio": ratio.max(0).tolist(), "frames_over_2": (ratio > 2.0).sum(0).tolist(),
            "peak_hip_reserve": np.abs(rho).max(0).tolist(), "peak_other_reserve": np.abs(res.reserve[:, 3:]).max(0).tolist(),
            "semimem_peak": float(f["semimem"].max()), "vasti_peak": float(sum(f[v] for v in VASTI).max()),
            "total_bw": (res.total / run["bw"]), "medial_bw": (res.medial / run["bw"]),
            "lateral_bw": (res.lateral / run["bw"]), "rho": rho, "iterations": getattr(res, "iterations", -1)}


def cells(r: dict) -> str:
    if not r["solved"]:
        return "did not solve: " + r["message"][:80] + " | | | | | |"
    c = r["comparison"]
    out = " | ".join(f"{c[k]['rmse_bw']:.3f} / {c[k]['r2']:.2f} / {c[k]['peak_error_bw']:+.2f}"
                     for k in ("medial", "lateral", "total"))
    return (out + " | " + " / ".join(f"{v:.1f}" for v in r["peak_ratio"]) + " | "
            + " / ".join(str(v) for v in r["frames_over_2"]) + " | " + " / ".join(f"{v:.1f}" for v in r["peak_hip_reserve"])
            + " | " + " / ".join(f"{v:.1f}" for v in r["peak_other_reserve"])
            + f" | {r['semimem_peak']:.0f} / {r['vasti_peak']:.0f}")


def figure(path: Path, trials: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(len(trials), 4, figsize=(17, 3.4 * len(trials)), squeeze=False)
    for i, (trial, d) in enumerate(trials.items()):
        t, tm, meas = np.asarray(d["t"]), np.asarray(d["t_measured"]), d["measured_bw"]
        for j, k in enumerate(("medial", "lateral", "total")):
            a = ax[i, j]
            a.plot(tm, meas[k], "k", lw=2, label="measured (eTibia)")
            for name, style in (("default, collocation", "C0--"), ("C19, collocation", "C3-"), ("C19, static", "C2:")):
                r = d["rows"][name]
                if r["solved"]:
                    a.plot(t, r[f"{k}_bw"], style, label=name)
            a.set_xlim(t[0], t[-1])
            a.set_title(f"{trial}: {k} (BW)")
        a = ax[i, 3]
        r = d["rows"]["C19, collocation"]
        for c, (name, col) in enumerate(zip(HIP_ROWS, ("C0", "C1", "C2"))):
            a.plot(t, 2 * np.asarray(d["sigma"])[:, c], col + "--", lw=1, label=f"2 sigma {name[4:]}")
            if r["solved"]:
                a.plot(t, np.abs(np.asarray(r["rho"])[:, c]), col + "-", label=f"|rho| {name[4:]}")
        a.set_title(f"{trial}: C19 collocation hip reserves (N m)")
        a.set_xlim(t[0], t[-1])
    ax[0, 0].legend(fontsize=7)
    ax[0, 3].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=75)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="ReducePoly_forMSK .../OpenSimModel/subject_GC")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    ap.add_argument("--no-sensitivity", action="store_true", help="skip the reported-only s values")
    args = ap.parse_args()
    clock, cpu = time.perf_counter(), time.process_time()
    head = ("| trial | model, method | medial RMSE / R^2 / peak error (BW) | lateral | total | peak abs(rho)/sigma "
            "flexion / adduction / rotation | frames over 2 sigma (of N) | peak hip reserves (N m) | peak knee / ankle / "
            "subtalar reserves (N m) | peak semimembranosus / vasti force (N) |")
    lines = [head, "|---|---|---|---|---|---|---|---|---|---|"]
    rule = {"collocation": {"solves": True, "hip within 2 sigma": True, "others within 10 N m": True},
            "static": {"solves": True, "hip within 2 sigma": True, "others within 10 N m": True}}
    sig_lines, times, trials, shift_lines = [], [], {}, []
    for trial in TRIALS:
        folder = J / "reducepoly_subject_GC" if trial == "ngait_og5" else args.data
        run = inputs(folder, trial)
        muscles = list(run["result"].muscles)
        hjc = {name: hjc_sigma(run["gait"], s) for name, s in [("C19", S_BELL_1989), *SENSITIVITY.items()]}
        sigma = np.sqrt(hjc["C19"] ** 2 + SIGMA_0 ** 2)
        N = len(run["gait"].t)
        sig_lines.append(f"| {trial} | {N} | " + " | ".join(
            f"{hjc['C19'][:, c].min():.2f} ... {hjc['C19'][:, c].max():.2f} (median {np.median(hjc['C19'][:, c]):.2f})"
            for c in range(3)) + f" | {np.linalg.norm(hip_force(run), axis=1).max() / run['bw']:.2f} |")
        tm, med, lat = run["measured"]
        trials[trial] = {"t": run["gait"].t.tolist(), "t_measured": tm, "sigma": sigma,
                         "measured_bw": {"medial": med / run["bw"], "lateral": lat / run["bw"],
                                         "total": (med + lat) / run["bw"]}, "rows": {}, "frames": N}
        plan = [("default, collocation", "collocation", None, sigma), ("C19, collocation", "collocation", "C19", sigma),
                ("default, static", "static", None, sigma), ("C19, static", "static", "C19", sigma)]
        if not args.no_sensitivity:
            plan += [(f"{name} (reported only), collocation", "collocation", name,
                      np.sqrt(hjc[name] ** 2 + SIGMA_0 ** 2)) for name in SENSITIVITY]
        forces = {}
        for name, method, which, sig in plan:
            weights = None if which is None else reserve_weights_per_frame(dict(zip(HIP_ROWS, hjc[which].T)))
            res, wall, proc = solve(run, method, weights)
            r = trials[trial]["rows"][name] = row(run, res, sig, muscles)
            times.append(f"{trial} {name}: {wall:.1f} s wall, {proc:.1f} s CPU")
            if which == "C19":
                rule[method]["solves"] &= r["solved"]
                if r["solved"]:
                    rule[method]["hip within 2 sigma"] &= max(r["peak_ratio"]) <= 2.0
                    rule[method]["others within 10 N m"] &= max(r["peak_other_reserve"]) <= 10.0
            lines.append(f"| {trial} | {name} | {cells(r)} |")
            print(lines[-1], flush=True)
            if name in ("default, collocation", "C19, collocation") and not isinstance(res, Exception):
                forces[name] = res.force
        shift_lines.append(muscle_shift(trial, trials[trial], forces, muscles))
    verdict = {m: all(v.values()) for m, v in rule.items()}
    text = ("# C19: hip reserves weighted by the hip-joint-centre error propagated through the inverse dynamics\n\n"
            "`python scripts/knee_c19_hjc_sigma.py --data <ReducePoly_forMSK 0b5ecfa>/ExampleTrackingSimulations/"
            "OpenSimModel/subject_GC` (preregistered: `preregistration.md`, seventh round). Default model (C13) "
            "otherwise; inverse dynamics once per trial. C19: `w_c(t) = 1/(2 (sigma_HJC,c(t)^2 + sigma_0^2))` on the "
            f"hip rows, `sigma_HJC,c = s |e_c x F_hip|`, `s = {1000 * S_BELL_1989:.1f} mm` (Bell, Brand, Pedersen "
            "1989: 95% within 2.6 cm, / 2.795), `sigma_0 = 1/sqrt(2)` N m; knee, ankle, subtalar `w = 1`. The "
            "ratios and the rule use the combined `sigma_c = sqrt(sigma_HJC^2 + sigma_0^2)` of C19 (of the row's own "
            "`s` for the reported-only rows). Loads: RMSE / R^2 / peak error against the eTibia (validation only).\n\n"
            + "\n".join(lines)
            + "\n\n## sigma_HJC,c(t) (N m) at s = 9.3 mm, flexion / adduction / rotation, and peak |F_hip|\n\n"
            "| trial | frames | flexion | adduction | rotation | peak abs(F_hip) (BW) |\n|---|---|---|---|---|---|\n"
            + "\n".join(sig_lines)
            + "\n\n## Where C19 moves the hip's work (collocation, at the frame of C19's largest adduction reserve)\n\n"
            "| trial | frame (s) | hip reserves default -> C19 (N m) | muscle forces default -> C19 (N), largest changes |"
            "\n|---|---|---|---|\n" + "\n".join(shift_lines)
            + "\n\n## Adoption rule (preregistration, seventh round)\n\n"
            + "\n".join(f"- {m}{' (decides)' if m == 'collocation' else ' (reported)'}: "
                        + "; ".join(f"{k}: {'yes' if v else 'no'}" for k, v in rule[m].items())
                        + f" -> **{'holds' if verdict[m] else 'fails'}**" for m in rule)
            + "\n\n## Solve times (loaded machine, 2 cores shared)\n\n" + "\n".join(f"- {x}" for x in times) + "\n")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "c19_hjc_sigma.md").write_text(text)
    slim = {t: {k: v for k, v in d.items() if k != "rows"} | {"rows": d["rows"]} for t, d in trials.items()}
    (args.out / "c19_hjc_sigma.json").write_text(json.dumps({"rule": rule, "verdict": verdict, "trials": slim},
                                                            default=lambda o: np.round(np.asarray(o, float), 4).tolist()))
    figure(args.out / "c19_hjc_sigma.png", trials)
    print(text)
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


def muscle_shift(trial: str, d: dict, forces: dict, muscles: list[str]) -> str:
    """One table row: at the frame of C19's (collocation) largest |adduction reserve|, the hip reserves and the eight
    muscles whose force changed most, default -> C19."""
    base, c19 = d["rows"]["default, collocation"], d["rows"]["C19, collocation"]
    if not (base["solved"] and c19["solved"]) or len(forces) < 2:
        return f"| {trial} | - | - | a collocation did not solve |"
    k = int(np.abs(np.asarray(c19["rho"])[:, 1]).argmax())
    f0, f1 = forces["default, collocation"][k], forces["C19, collocation"][k]
    order = np.argsort(-np.abs(f1 - f0))[:8]
    rho = " / ".join(f"{np.asarray(base['rho'])[k, c]:+.1f} -> {np.asarray(c19['rho'])[k, c]:+.1f}" for c in range(3))
    return (f"| {trial} | {d['t'][k]:.3f} | {rho} | "
            + ", ".join(f"{muscles[i]} {f0[i]:.0f} -> {f1[i]:.0f}" for i in order) + " |")


def hip_force(run: dict) -> np.ndarray:
    from ocp_constraints.biomech.knee_id_uncertainty import hip_force_and_axes

    return hip_force_and_axes(run["gait"])[0]


if __name__ == "__main__":
    main()
