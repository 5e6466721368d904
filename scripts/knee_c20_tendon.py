"""Issue 15, candidate C20: the default (C13, collocation with activation dynamics) with Hill muscles with compliant
tendons (De Groote et al. 2016 implicit tendon-force form, :mod:`ocp_constraints.biomech.knee_tendon`).

    python scripts/knee_c20_tendon.py --data R/ExampleTrackingSimulations/OpenSimModel/subject_GC [--out results/knee]

Preregistered in ``results/knee/preregistration.md`` (eighth round, commit 8eb6619, before any C20 load was
computed). Per trial (ngait_og5 from the shared data, bouncy7 and mtpgait3 from ``--data``): the default ``knee`` run's
inputs (inverse dynamics once), then the default (collocation, ideal muscles), the rigid-tendon Hill model under the
default method (``--muscle-model hill``; comparison only) and C20. Writes ``<out>/c20_tendon.md`` and ``.json``:
RMSE / R^2 / peak error per compartment, peak reserves, iterations, solve time (wall and CPU), the residuals at the
solution, the rule's conditions; and the timing of the whole knee command with C20 on ngait_og5 (inverse dynamics,
model data, frame data and the C20 solve in one process: ``--command-runs``, median).
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
from ocp_constraints.biomech.knee_collocation import solve_collocation_or_static  # noqa: E402
from ocp_constraints.biomech.knee_hill import scale_lengths  # noqa: E402
from ocp_constraints.biomech.knee_muscles import MusclePaths, muscle_parameters  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED, muscle_kinematics, solve_static  # noqa: E402
from ocp_constraints.biomech.knee_tendon import solve_tendon  # noqa: E402
from ocp_constraints.errors import KneeError  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")
SHOW = ("gasmed", "gaslat", "soleus", "semimem", "recfem", "vaslat", "vasmed", "vasint")


def files(folder: Path, trial: str) -> list[Path]:
    return [folder / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")]


def inputs(folder: Path, trial: str) -> dict:
    """The default ``knee`` run's inputs (static, ideal muscles), captured at its solver call, plus the units'
    kinematics and the scaled Hill parameters."""
    seen = {}

    def capture(t, Qc, R, A, F0, **kw):
        seen.update(args=(t, Qc, R, A, F0), kw=kw)
        return solve_static(t, Qc, R, A, F0, **kw)

    kp.solve_static = capture
    try:
        run = kp.run_knee(MODEL, *files(folder, trial), method="static")
    finally:
        kp.solve_static = solve_static
    run.update(seen)
    paths = MusclePaths(run["model_data"].muscle_paths)
    run["muscles"] = paths.muscles
    params = muscle_parameters(MODEL, paths.muscles)
    l_opt, l_s, alpha0 = (np.array([getattr(params[m], k) for m in paths.muscles]) for k in
                          ("optimal_fiber_length", "tendon_slack_length", "pennation_angle"))
    L_ref = np.asarray(paths.unit_length(paths.q_vector({}))).ravel()
    _, l_opt, l_s = scale_lengths(L_ref, l_opt, l_s, alpha0)     # as the rigid Hill model (preregistration)
    L, V = muscle_kinematics(run["gait"], paths)
    run["tendon"] = dict(L_mt=L, V_mt=V, l_opt=l_opt, l_slack=l_s, alpha0=alpha0,
                         passive_rows=[RESERVED.index(c) for c in run["passive_moments"]])
    return run


QUADRICEPS = ("recfem", "vaslat", "vasmed", "vasint")


def window_lines(trial: str, run: dict, rows: dict, hill: dict, res) -> list[str]:
    """Stance and swing means of the loads (measured interpolated to the frames) and of the quadriceps' passive
    fibre force, rigid Hill (``hill["hill"].passive``) and C20 (``F0 f_PE(l~M) cos(alpha)`` at its fibre lengths)."""
    from ocp_constraints.biomech.knee_tendon_curves import passive_force_length

    t = np.asarray(run["gait"].t)
    tm, med, lat = run["measured"]
    meas = {"medial": np.interp(t, tm, med), "lateral": np.interp(t, tm, lat)}
    meas["total"] = meas["medial"] + meas["lateral"]
    q = [run["muscles"].index(m) for m in QUADRICEPS]
    F0 = np.asarray(run["args"][4], float)
    rigid_p = hill["hill"].passive[:, q].sum(1)
    c20_p = None
    if not isinstance(res, Exception):
        l = res.fibre_length[:, q]
        sin0 = np.sin(run["tendon"]["alpha0"][q])
        c20_p = (F0[q] * passive_force_length(l) * np.sqrt(1.0 - (sin0 / l) ** 2)).sum(1)
    out = []
    for phase in ("stance", "swing"):
        keep = np.zeros(len(t), bool)
        for a, b, kind in run["phases"]:
            if kind == phase:
                keep |= (t >= a) & (t <= b)
        cells = [" / ".join(f"{meas[k][keep].mean() / run['bw']:.2f}" for k in ("medial", "lateral", "total"))]
        for name in ("default (collocation, ideal muscles)", "rigid-tendon Hill (collocation; comparison)",
                     "C20: compliant tendon"):
            r = rows[name]
            cells.append(" / ".join(f"{np.asarray(r[f'{k}_bw'])[keep].mean():.2f}" for k in ("medial", "lateral", "total"))
                         if r["solved"] else "-")
        cells.append(f"{rigid_p[keep].mean():.0f} / {rigid_p[keep].max():.0f}")
        cells.append("-" if c20_p is None else f"{c20_p[keep].mean():.0f} / {c20_p[keep].max():.0f}")
        out.append(f"| {trial} | {phase} ({keep.sum()}) | " + " | ".join(cells) + " |")
    return out


def c20(run: dict, **kw):
    t, Qc, R, A, F0 = run["args"]
    return solve_tendon(t, Qc, R, A, F0, **run["tendon"], reserve_weight=run["kw"].get("reserve_weight", 1.0), **kw)


def timed(fn, *a, **kw):
    clock, cpu = time.perf_counter(), time.process_time()
    try:
        res = fn(*a, **kw)
    except KneeError as exc:
        res = exc
    return res, time.perf_counter() - clock, time.process_time() - cpu


def row(run: dict, res, wall: float, cpu: float) -> dict:
    if isinstance(res, Exception) or getattr(res, "fallback", None):
        return {"solved": False, "message": str(res if isinstance(res, Exception) else res.fallback),
                "wall": wall, "cpu": cpu}
    res.muscles = run["muscles"]
    c = kp.compare(res.t, {"medial": res.medial, "lateral": res.lateral, "total": res.total}, run["measured"], run["bw"])
    f = dict(zip(run["muscles"], res.force.T))
    out = {"solved": True, "comparison": c, "peak_reserve": np.abs(res.reserve).max(0).tolist(),
           "iterations": getattr(res, "iterations", -1), "wall": wall, "cpu": cpu,
           "balance_residual": res.residual, "ode_residual": getattr(res, "ode_residual", float("nan")),
           "peak_force": {m: float(f[m].max()) for m in SHOW},
           "medial_bw": res.medial / run["bw"], "lateral_bw": res.lateral / run["bw"], "total_bw": res.total / run["bw"]}
    if hasattr(res, "tendon_force") and res.tendon_force is not None:
        i = [run["muscles"].index(m) for m in SHOW]
        out.update(equilibrium_residual=res.equilibrium_residual, tendon_defect=res.tendon_defect,
                   fibre_length_range={m: [float(res.fibre_length[:, j].min()), float(res.fibre_length[:, j].max())]
                                       for m, j in zip(SHOW, i)})
    return out


def cells(r: dict) -> str:
    if not r["solved"]:
        return f"did not solve: {r['message'][:120]} | | | | | {r['wall']:.1f} / {r['cpu']:.1f} |"
    c = r["comparison"]
    return (" | ".join(f"{c[k]['rmse_bw']:.3f} / {c[k]['r2']:.2f} / {c[k]['peak_error_bw']:+.2f}"
                       for k in ("medial", "lateral", "total"))
            + " | " + " / ".join(f"{v:.1f}" for v in r["peak_reserve"]) + f" | {r['iterations']} | "
            + f"{r['wall']:.1f} / {r['cpu']:.1f} |")


def command_time(runs: int) -> list[tuple[float, float]]:
    """The whole knee command with C20 on ngait_og5, in this process: inputs (model data, inverse dynamics, frame
    data, muscle kinematics) and the C20 solve (the default's static solve inside ``inputs`` is not part of it and
    is subtracted)."""
    out = []
    folder = J / "reducepoly_subject_GC"
    for _ in range(runs):
        clock, cpu = time.perf_counter(), time.process_time()
        run = inputs(folder, "ngait_og5")
        static = run["step_times"]["static"]
        c20(run)
        out.append((time.perf_counter() - clock - static["wall"], time.process_time() - cpu - static["cpu"]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="ReducePoly_forMSK .../OpenSimModel/subject_GC")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    ap.add_argument("--trials", nargs="+", default=list(TRIALS))
    ap.add_argument("--command-runs", type=int, default=3)
    args = ap.parse_args()
    clock, cpu = time.perf_counter(), time.process_time()
    lines = ["| trial | model | medial RMSE / R^2 / peak error (BW) | lateral | total | peak reserves hip flex / add / "
             "rot / knee / ankle / subtalar (N m) | IPOPT iterations | solve wall / CPU (s) |",
             "|---|---|---|---|---|---|---|---|"]
    checks, forces, windows, rule, data = [], [], [], {"solves": True, "knee/ankle/subtalar reserves <= 10 N m": True}, {}
    for trial in args.trials:
        folder = J / "reducepoly_subject_GC" if trial == "ngait_og5" else args.data
        run = inputs(folder, trial)
        t, Qc, R, A, F0 = run["args"]
        rows = {}
        rows["default (collocation, ideal muscles)"] = row(run, *timed(solve_collocation_or_static, t, Qc, R, A, F0,
                                                                       **run["kw"]))
        hill = kp.run_knee(MODEL, *files(folder, trial), muscle_model="hill", method="collocation")
        r = hill["result"]
        rows["rigid-tendon Hill (collocation; comparison)"] = row(run, r, r.timings["build"] + r.timings["solve"],
                                                                   float("nan"))
        res20 = timed(c20, run)
        rows["C20: compliant tendon"] = r20 = row(run, *res20)
        windows.extend(window_lines(trial, run, rows, hill, res20[0]))
        rule["solves"] &= r20["solved"]
        if r20["solved"]:
            rule["knee/ankle/subtalar reserves <= 10 N m"] &= max(r20["peak_reserve"][3:]) <= 10.0
            checks.append(f"| {trial} | {r20['equilibrium_residual']:.1e} | {r20['tendon_defect']:.1e} | "
                          f"{r20['ode_residual']:.1e} | {r20['balance_residual']:.1e} |")
            forces.append(f"| {trial} | " + " | ".join(
                f"{rows['rigid-tendon Hill (collocation; comparison)']['peak_force'][m]:.0f} -> "
                f"{r20['peak_force'][m]:.0f} ({r20['fibre_length_range'][m][0]:.2f}-{r20['fibre_length_range'][m][1]:.2f})"
                for m in SHOW) + " |")
        for name, r in rows.items():
            lines.append(f"| {trial} | {name} | {cells(r)}")
            print(lines[-1], flush=True)
        tm, med, lat = run["measured"]
        data[trial] = {"t": run["gait"].t, "t_measured": tm, "measured_bw": {"medial": med / run["bw"],
                       "lateral": lat / run["bw"], "total": (med + lat) / run["bw"]}, "rows": rows}
    times = command_time(args.command_runs) if args.command_runs else []
    if times:
        rule["whole knee command <= 5 s wall (median)"] = float(np.median([w for w, _ in times])) <= 5.0
    verdict = all(rule.values())
    text = ("# C20: Hill muscles with a compliant tendon (De Groote et al. 2016, implicit tendon-force form)\n\n"
            "`python scripts/knee_c20_tendon.py --data <ReducePoly_forMSK 0b5ecfa>/ExampleTrackingSimulations/"
            "OpenSimModel/subject_GC` (preregistered: `preregistration.md`, eighth round, 8eb6619). The default "
            "model (C13, Riener & Edrich's passive moments, collocation with activation dynamics) with each muscle's "
            "tension the tendon force `F0 F~T` (`ocp_constraints/biomech/knee_tendon.py`); the rigid-tendon Hill row "
            "is `--muscle-model hill --method collocation` (the same scaled lengths), for comparison. Loads against "
            "the eTibia: RMSE / R^2 / peak error (BW), validation only. Times on a loaded machine (2 cores shared).\n\n"
            + "\n".join(lines)
            + "\n\n## C20 at the solution: largest residuals\n\n| trial | equilibrium (F0) | tendon-force defect (F0) | "
            "activation defect | balance (N m or N) |\n|---|---|---|---|---|\n" + "\n".join(checks)
            + "\n\n## Peak muscle forces (N), rigid-tendon Hill -> C20, and C20's fibre length range (l_opt)\n\n| trial | "
            + " | ".join(SHOW) + " |\n|" + "---|" * (len(SHOW) + 1) + "\n" + "\n".join(forces)
            + "\n\n## Where the load is: means over the right foot's stance and swing frames (BW), and the quadriceps' "
            "passive fibre force (recfem + vasti, N: mean / peak over those frames)\n\n| trial | phase (frames) | measured "
            "medial / lateral / total | default | rigid-tendon Hill | C20 | quadriceps passive, rigid Hill | "
            "quadriceps passive, C20 |\n|---|---|---|---|---|---|---|---|\n" + "\n".join(windows)
            + "\n\n## Whole knee command with C20 on ngait_og5 (one process; wall / CPU, s)\n\n"
            + ("\n".join(f"- {w:.2f} / {c:.2f}" for w, c in times) + (f"\n- median wall {np.median([w for w, _ in times]):.2f} s"
                                                                          if times else "") if times else "- not measured")
            + "\n\n## Rule (preregistration, eighth round)\n\n"
            + "\n".join(f"- {k}: {'yes' if v else 'no'}" for k, v in rule.items())
            + f"\n- **{'adopted by the rule' if verdict else 'reported only'}**\n")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "c20_tendon.md").write_text(text)
    (args.out / "c20_tendon.json").write_text(json.dumps({"rule": rule, "verdict": verdict, "trials": data,
                                                          "command_times": times},
                                                         default=lambda o: np.round(np.asarray(o, float), 4).tolist()))
    print(text)
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
