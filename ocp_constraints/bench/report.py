"""Orchestration and report of ``ocp-constraints bench`` (see :mod:`ocp_constraints.bench.work_precision`)."""
from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path

import numpy as np

from .defaults import QUICK_SCENES
from .work_precision import (
    LAMBDA_TARGET,
    cheapest,
    machine,
    markdown_table,
    peer_ratios,
    plot_multiplier_floor,
    plot_work_precision,
    run_peers,
    write_csv_rows,
)
from .sweeps import (
    OCP_TASKS,
    OCP_WITHOUT_REFERENCE,
    SIM_SCENES,
    sweep_ocp,
    sweep_sim,
)
from ..errors import SceneError
from ..output.files import prepare_output_folder, replace_between_markers, write_atomic
from ..scenes.registry import builtin_scene_names


def _fmt(row) -> str:
    if row is None:
        return "not reached by any measured setting"
    return (f"{row.setting} ({row.kind}): {row.total_s:.3f} s (build {row.build_s:.3f} s + solve {row.solve_s:.3f} s), "
            f"state error {row.state_err:.1e}, lambda error {row.lambda_err:.1e}")


def run_bench(args) -> int:
    started = time.perf_counter()
    all_scenes = builtin_scene_names()
    scenes = list(args.scenes) or list(QUICK_SCENES if args.quick else all_scenes)
    unknown = [s for s in scenes if s not in all_scenes]
    if unknown:
        raise SceneError(f"bench: unknown scene(s) {unknown}; built-in scenes: {', '.join(all_scenes)}")
    if args.runs < 3:
        raise SceneError(f"bench: --runs must be at least 3 (medians of 3 or more runs), got {args.runs}")
    if not (np.isfinite(args.target_error) and args.target_error > 0):
        raise SceneError(f"bench: --target-error must be a positive number, got {args.target_error}")
    if getattr(args, "readme", None):
        splice_readme(Path(args.readme), None, Path(args.out))  # fail now, not after the run
    out = prepare_output_folder(args.out)
    runs = args.runs
    by_scene: dict[str, list] = {s: [] for s in scenes}
    info: dict[str, dict] = {s: {} for s in scenes}
    for s in scenes:
        print(f"== {s}")
        if s in OCP_TASKS and (not args.quick or s == "pendulum"):
            rows, meta = sweep_ocp(s, args.quick, runs)
            by_scene[s] += rows
            info[s]["ocp"] = meta
        if s in SIM_SCENES:
            rows, meta = sweep_sim(s, args.quick, runs, 2.0 if args.quick else 10.0)
            by_scene[s] += rows
            info[s]["sim"] = meta
    print("== peers")
    peer_rows, notes = run_peers(scenes, args.quick, runs)
    for r in peer_rows:
        by_scene[r.scene].append(r)
    for n in notes:
        print(f"  {n}")
    ratios = peer_ratios([r for rs in by_scene.values() for r in rs])
    scaling = None
    if not args.no_scaling and not args.quick:
        from .scaling import run_scaling_and_stress

        print("== scaling and slow stress cases")
        scaling = run_scaling_and_stress()
    summary = {"machine": machine(), "quick": args.quick, "runs": runs, "scenes": {}, "peer_ratios": ratios, "peer_notes": notes,
               "scaling": scaling}
    print(f"== recommendations (target error {args.target_error:g}; error = max(state error, relative lambda error))")
    for s in scenes:
        rows = by_scene[s]
        if not rows:
            continue
        write_csv_rows(out / f"{s}.csv", rows)
        write_atomic(out / f"{s}.md", markdown_table(rows).encode())
        plot_work_precision(out / f"{s}_work_precision.png", s, rows)
        rec = {k: cheapest(rows, args.target_error, kinds=(k,)) for k in ("ocp", "sim")}
        lam = {k: cheapest(rows, LAMBDA_TARGET, key=lambda r: r.lambda_err, kinds=(k,)) for k in ("ocp", "sim")}
        summary["scenes"][s] = {"info": info[s], "target": {k: None if v is None else v.setting for k, v in rec.items()},
                                "lambda_1e-8": {k: None if v is None else {"setting": v.setting, "total_s": v.total_s,
                                                                           "lambda_err": v.lambda_err} for k, v in lam.items()}}
        for k in ("ocp", "sim"):
            if any(r.kind == k for r in rows):
                print(f"  {s} {k}: cheapest reaching {args.target_error:g}: {_fmt(rec[k])}")
                print(f"  {s} {k}: cheapest with lambda error <= 1e-8: {_fmt(lam[k])}")
    sim_rows = [r for rs in by_scene.values() for r in rs if r.kind in ("sim", "peer-sim")]
    if sim_rows:   # every scene's multiplier error against the tolerance, in one figure (issue 14)
        write_atomic(out / "multiplier_floor.md", plot_multiplier_floor(out / "multiplier_floor.png", sim_rows).encode())
    summary["duration_s"] = time.perf_counter() - started
    write_atomic(out / "summary.json", json.dumps(summary, indent=1, default=str).encode())
    write_atomic(out / "peers.md", _peer_markdown(ratios, notes).encode())
    section = _readme_section(by_scene, summary, args)
    write_atomic(out / "README_section.md", section.encode())
    if getattr(args, "readme", None):
        splice_readme(Path(args.readme), section, out)
        print(f"  {args.readme}: section between the bench markers replaced")
    print(f"bench finished in {summary['duration_s']:.0f} s; results in {out}")
    return 0


README_START = "<!-- bench section: written by `ocp-constraints bench --readme README.md` -->"
README_END = "<!-- end of bench section -->"


def splice_readme(readme: Path, section: str | None, out: Path) -> None:
    """Replace the text between the bench markers of ``readme`` by ``section`` (its title
    dropped, image links made relative to the README). ``section=None`` only checks."""
    body = None
    if section is not None:
        prefix = os.path.relpath(out.resolve(), readme.resolve().parent).replace(os.sep, "/")
        body = section.split("\n", 1)[1].lstrip("\n")
        body = re.sub(r"\]\(([^)/]+\.png)\)", lambda m: f"]({prefix}/{m.group(1)})", body)
    replace_between_markers(readme, README_START, README_END, body, "bench --readme")


def _peer_markdown(ratios: list[dict], notes: list[str]) -> str:
    lines = ["| scene | peer setting | peer error | peer time (s) | our cheapest setting at equal or better error | our error | ratio ours/peer (total) | ratio (solve only) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in ratios:
        if r["ours"] is None:
            lines.append(f"| {r['scene']} | {r['peer']} | {r['peer_error']:.1e} | {r['peer_total_s']:.3f} | none of ours reaches it | | | |")
        else:
            lines.append(f"| {r['scene']} | {r['peer']} | {r['peer_error']:.1e} | {r['peer_total_s']:.3f} | {r['ours']} | "
                         f"{r['our_error']:.1e} | {r['ratio_total']:.2f} | {r['ratio_solve']:.2f} |")
    return "\n".join(lines + [""] + [f"- {n}" for n in notes]) + "\n"


def _readme_section(by_scene: dict, summary: dict, args) -> str:
    m = summary["machine"]
    cmd = "ocp-constraints bench" + (" --quick" if args.quick else "") + (f" --out {args.out}" if args.out != "results/bench" else "")
    cmd += f" --readme {args.readme}" if getattr(args, "readme", None) else ""
    lines = ["## Accuracy and speed", "",
             f"Regenerated by `{cmd}` ({summary['duration_s'] / 60:.1f} min on this machine: {m['cpus']} cores, "
             f"Python {m['python']}, CasADi {m['casadi']}, {m['date']}). Every time is the median of {summary['runs']} runs; "
             "each error is measured against the row's `reference`. A closed form, Pontryagin's conditions or a "
             "hand-written balance there is an independent reference (another derivation, another method). \"DOP853 "
             "rtol 1e-13 on the library's equations\" (SciPy's integrator) and \"fine ...\" (the other collocation "
             "family on a fine mesh) are high-accuracy solutions of the library's own equations by a different method: "
             "those rows measure the integrator or the discretization and their settings, not the equations, which the "
             "test suite checks against Lagrange's equations and closed forms (sliding_disk: states so, multipliers by "
             "eq. (4)). "
             "Error = max(state error in SI units, multiplier error relative to the scene's largest reference multiplier).", "",
             "| scene | kind | reference | cheapest setting with lambda error <= 1e-8 | its time (s) |", "|---|---|---|---|---|"]
    for s, rows in by_scene.items():
        for k in ("ocp", "sim"):
            if not any(r.kind == k for r in rows):
                continue
            ref = summary["scenes"].get(s, {}).get("info", {}).get(k, {}).get("reference", "")
            lam = summary["scenes"].get(s, {}).get("lambda_1e-8", {}).get(k)
            lines.append(f"| {s} | {k} | {ref} | {lam['setting'] if lam else 'not reached'} | "
                         f"{lam['total_s']:.3f} |" if lam else f"| {s} | {k} | {ref} | not reached | |")
    lines += ["", "Radau rows report the multiplier error without t = 0, where Radau collocation has no defect of its "
              "own (its inputs there are extrapolated from the first interval); the column `lambda error at t0` in the "
              "tables has it.", ""]
    lines += [f"No optimal-control sweep for {s}: {why}." for s, why in OCP_WITHOUT_REFERENCE.items() if s in by_scene]
    lines += ["", "### Peers (same run)", "",
              _peer_markdown(summary["peer_ratios"], summary["peer_notes"])]
    if summary.get("scaling"):
        lines += ["### Scaling", "", summary["scaling"]["markdown"], ""]
    lines += ["### Work-precision plots and tables", ""]
    for s, rows in by_scene.items():
        if rows:
            lines += [f"![{s}]({s}_work_precision.png)", "", f"<details><summary>{s} table</summary>", "",
                      markdown_table(rows), "</details>", ""]
    return "\n".join(lines)
