"""Textbook holdouts for accuracy on request (issue 19): ``problem.solve(tolerance=...)`` measured against
independent references on five problems written from scratch through the public API (``import
ocp_constraints as oc``), none used to tune the refinement.

    python scripts/refinement_holdouts.py [--tolerances 1e-3 1e-4 1e-5 1e-6] [--problems NAME ...] [--cpu-cap 120]
        [--no-fixed] [--fixed-degrees 3 5 7] [--fixed-intervals 5 10 20 40 80 160] [--experiment clean-effect]
        [--out results/bench/refinement_holdouts.md] [--notes NOTES.md] [--table-only]

A problem's section in --out is replaced by its re-run, the others kept. Problems (scripts/refinement_holdout_problems.py):
``bang_bang``, ``bang_bang_asym``, ``clipped``, ``hinge``, ``clipped_upper``. The committed tables were made against a
snapshot of the library (``git archive <commit> ocp_constraints | tar -x -C DIR``, then ``PYTHONPATH=DIR``), so that
work in progress in the shared tree does not enter them; the markdown's command lines name it.

True errors are measured as the estimate defines its quantities (ocp/error_estimate.py's notes), on 4 times per
collocation point of every interval of the final mesh, the reference at the same fraction of its horizon
(as the estimate compares its companion; at a sample on a jump, the nearer of its two sides): states absolute (all 12 coordinates and speeds, SI),
multipliers relative to the reference's largest |lambda|, inputs relative to the reference's largest |input|,
both without t = 0, and (as the estimate does) without the jump windows the record names; the multipliers'
and inputs' error over every t > 0 is shown too. Each refined solve runs in its own process under a CPU cap
(RLIMIT_CPU); CPU is ``time.process_time`` of ``problem.solve`` (after one untimed warm-up solve of a
separate problem instance in the same process, which pays CasADi's first-use costs), wall beside it. The
fixed meshes are uniform Radau 3/5/7 on 5-160 intervals, cold-started, in one process per problem; the
cheapest is the one of least CPU whose true errors (states, multipliers and inputs, final time) are at most the
tolerance, the multipliers and inputs measured as for the refined solution: at a jump (bang_bang) without the
interval the jump touches (:func:`reference_windows`), as the estimate leaves it out; the inputs are not gated
by the refinement, but a fixed mesh is judged on what it delivers (the column shows the cheapest on states and
multipliers alone too). CPU of the fixed meshes is the fastest of one cold solve each: noisy on a shared machine.
"""
from __future__ import annotations

import argparse
import importlib.util
import multiprocessing as mp
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

import ocp_constraints as oc


def _load_problems():
    """scripts/refinement_holdout_problems.py as a module (scripts/ is no package; registered by name first,
    which its dataclass needs)."""
    name = "refinement_holdout_problems"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


problems = _load_problems()
PROBLEMS, Reference = problems.PROBLEMS, problems.Reference
M, G, ROD_M = problems.M, problems.G, problems.ROD_M

PER_POINT = 4
FIXED_DEGREES = (3, 5, 7)
FIXED_INTERVALS = (5, 10, 20, 40, 80, 160)


# -- true errors -------------------------------------------------------------------------------------------------
def sample_fractions(mesh, degrees, per_point: int = PER_POINT) -> np.ndarray:
    """``per_point`` times per collocation point, evenly in every interval, its ends included (fractions)."""
    return np.concatenate([np.linspace(a, b, per_point * d + 1) for a, b, d in zip(mesh[:-1], mesh[1:], degrees)])


def true_errors(sol, ref: Reference, mesh, degrees, windows=()) -> dict:
    """True errors per quantity as the estimate defines them (module notes), and where each is largest (s)."""
    names = {"states": sol.transcription.problem.model.coordinate_names + sol.transcription.problem.model.speed_names,
             "multipliers": [c for c in sol.sample_columns() if c.endswith(".lambda")],
             "inputs": list(sol.transcription.problem.model.inputs)}
    f = sample_fractions(mesh, degrees)
    t = f * sol.t_final
    # The reference at the same fraction of its own horizon (as the estimate compares a companion), from both
    # sides: where a jump falls on a sample (a mesh point at the switch), either side's value is the solution's.
    sides = [ref.values(np.clip(f * ref.t_final + e, 0.0, ref.t_final)) for e in (-1e-12, 1e-12)]
    inner = f > 0.0
    outside = inner.copy()
    for lo, hi in windows:
        outside &= (f < lo) | (f > hi)
    out = {}
    for q, labels in names.items():
        ours = np.array([sol.polynomial(n, t) for n in labels])
        left, right = (np.array([side[n] for n in labels]) for side in sides)
        scale = 1.0 if q == "states" else max(float(np.abs(left[:, inner]).max()), 1e-300)
        diff = np.minimum(np.abs(ours - left), np.abs(ours - right)).max(axis=0) / scale
        for key, mask in ((q, outside if q != "states" else np.ones_like(inner)), (f"{q}_all", inner)):
            if q == "states" and key.endswith("_all"):
                continue
            d = np.where(mask, diff, 0.0)
            out[key] = float(d.max())
            out[f"{key}_at"] = float(t[int(d.argmax())])
    out["t_final"] = abs(sol.t_final - ref.t_final)
    out["objective"] = abs(sol.objective - ref.objective) / abs(ref.objective)
    return out


# -- runs --------------------------------------------------------------------------------------------------------
def _warm_up(build) -> None:
    """One small untimed solve of a separate instance: CasADi's and IPOPT's first-use costs out of the timing."""
    build().solve(oc.Radau(4, degree=3), progress=False)


def _short_intervals(mesh: np.ndarray, T: float, k: int = 4) -> str:
    w = np.diff(mesh)
    order = np.argsort(w)[:k]
    return ", ".join(f"{mesh[i] * T:.5g}-{mesh[i + 1] * T:.5g}" for i in sorted(order))


def clean_effect_experiment() -> None:
    """An experiment, not the library (``--experiment clean-effect``; nothing under ocp_constraints/ is edited, the
    refinement's own name for the switch detection is rebound in this process only): a junction's ``effect`` set
    to 0 (it models a jump: a clean step of the accelerations, and a jump put at the nearest mesh point; at a kink
    the accelerations are continuous), and a jump that the detection itself puts at the mesh point
    (``inside`` False) measured from that mesh point, not from the middle-of-the-bounds crossing half a gap later,
    over the bracket's points after the mesh point (a trapezoid from the mesh point, whose accelerations are the
    interval before's, charges |jump| x half the gap to the first collocation point whatever the NLP did).
    What the states' estimate then is shows what the effect's floor did (results/bench/refinement_holdouts.md)."""
    import dataclasses

    import ocp_constraints.ocp.mesh_refinement as mr
    from ocp_constraints.ocp import switch_detection as sd

    original = sd.detect_switches

    def detect(solution):
        tr = solution.transcription
        mesh, frac = tr.scheme.mesh_fractions, tr.fractions
        D, T = np.asarray(solution.D, float), float(solution.t_final)
        out = []
        for w in original(solution):
            if w.kind == "junction":
                w = dataclasses.replace(w, effect=0.0)
            elif not w.inside and D.size:
                # From the mesh point on: its accelerations are the interval before's (Radau), and a trapezoid from
                # there to the first collocation point charges |jump| x half that gap whatever the NLP did.
                i, j = (int(np.argmin(np.abs(frac - b))) for b in w.bracket)
                i += int(abs(frac[i] - mesh[w.interval]) < 1e-12)
                effect = sd._effect(frac[i:j + 1] * T, D[:, i:j + 1], mesh[w.interval] * T, mesh, T) if j > i else 0.0
                w = dataclasses.replace(w, effect=effect)
            out.append(w)
        return out

    mr.detect_switches = detect


def refined_run(name: str, tolerance: float, experiment: str | None = None) -> dict:
    """``problem.solve(tolerance=...)`` on holdout ``name``; the record, true errors and timings."""
    if experiment == "clean-effect":
        clean_effect_experiment()
    build, reference = PROBLEMS[name]
    ref = reference()
    _warm_up(build)
    problem = build()
    cpu, wall = time.process_time(), time.perf_counter()
    sol = problem.solve(tolerance=tolerance, progress=False)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    rec = sol.mesh_refinement
    mesh, degrees = np.array(rec["mesh"]), rec["degrees"]
    windows = [tuple(w) for w in rec.get("jump_windows", [])]
    hist = rec["history"]
    T = sol.t_final
    # Diagnosis only (library internals, read not changed): the switches located on the final solution, and the
    # jump windows where the record has none (it records them only when it checks smoothness, not when it stops
    # on intervals that cannot be refined further); the estimate left those out all the same.
    from ocp_constraints.ocp.switch_detection import detect_switches, jump_windows
    found = detect_switches(sol)
    located = [(w.kind, w.quantity, w.fraction * T, (w.bracket[0] * T, w.bracket[1] * T), w.effect) for w in found]
    windows_from = "record"
    if not windows and any(w.kind == "bang-bang" for w in found):
        windows, windows_from = jump_windows(found, mesh), "located on the solution (not in the record)"
    nearest = {s: float(np.abs(mesh * T - s).min()) for s in ref.switches}
    loads = sol.loads()
    normal = ("rail.v2.lambda", M * G) if "rail.v2.lambda" in loads else ("hinge.v3.lambda", ROD_M * G)
    return {"problem": name, "tolerance": tolerance, "met": bool(rec["met"]), "message": rec["message"],
            "refinements": rec["refinements"], "solves": int(sum(h.get("solves", 0) for h in hist)),
            "iterations": int(sum(h.get("iterations", 0) + h.get("companion_iterations", 0) for h in hist)),
            "per_mesh": [(h["points"], h.get("iterations", 0), h.get("companion_iterations"),
                          {q: h.get("estimate", {}).get(q) for q in ("states", "multipliers")}) for h in hist],
            "intervals": len(mesh) - 1, "points": hist[-1]["points"], "degrees": [min(degrees), max(degrees)],
            "widths": [float(np.diff(mesh).min() * T), float(np.diff(mesh).max() * T)],
            "short": _short_intervals(mesh, T), "switch_gap": nearest, "windows": windows,
            "estimate": dict(rec["estimate"]), "true": true_errors(sol, ref, mesh, degrees, windows),
            "normal_force_error": float(np.abs(loads[normal[0]] - normal[1]).max()),
            "t_final": T, "cpu": cpu, "wall": wall, "located": located, "windows_from": windows_from,
            "reference_jumps": ref.jumps}


def reference_windows(ref: Reference, mesh: np.ndarray) -> list[tuple[float, float]]:
    """For a fixed mesh, the windows the estimate would leave out at the reference's jumps: the interval after
    a jump that falls on a mesh point (Radau's inputs and multipliers there are interpolated through the mesh
    point's value, the interval before's), else the interval holding it. None where nothing jumps."""
    out = []
    for s in (ref.switches if ref.jumps else ()):
        f = s / ref.t_final
        k = int(np.argmin(np.abs(mesh - f)))
        k = k if abs(mesh[k] - f) < 1e-9 and k < len(mesh) - 1 else int(np.searchsorted(mesh, f) - 1)
        out.append((float(mesh[k]), float(mesh[k + 1])))
    return out


def fixed_sweep(name: str, degrees=FIXED_DEGREES, intervals=FIXED_INTERVALS, cap: float = 30.0) -> list[dict]:
    """Uniform Radau meshes solved cold: true errors and CPU each; a degree stops after a solve over ``cap`` s
    of CPU, and IPOPT stops a solve at 4 ``cap`` (its row then says so)."""
    build, reference = PROBLEMS[name]
    ref = reference()
    _warm_up(build)
    rows = []
    for d in degrees:
        for n in intervals:
            problem = build()
            cpu, wall = time.process_time(), time.perf_counter()
            try:
                sol = problem.solve(oc.Radau(n, degree=d), {"ipopt.max_cpu_time": 4 * cap}, progress=False)
                status = sol.status
            except oc.OCPSolveError as exc:     # a failed fixed mesh: its row says so, no error measured
                rows.append({"degree": d, "intervals": n, "status": str(exc)[:80], "cpu": time.process_time() - cpu})
                if time.process_time() - cpu > cap:
                    break
                continue
            cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
            mesh = np.linspace(0.0, 1.0, n + 1)
            rows.append({"degree": d, "intervals": n, "points": n * d + 1, "status": status, "cpu": cpu, "wall": wall,
                         "true": true_errors(sol, ref, mesh, [d] * n, reference_windows(ref, mesh))})
            print(f"  fixed radau{d} N={n}: {status}, {cpu:.2f} s CPU", file=sys.stderr, flush=True)
            if cpu > cap:
                break
    return rows


def _child(target, args, queue, cpu_cap: float) -> None:
    resource.setrlimit(resource.RLIMIT_CPU, (int(cpu_cap), int(cpu_cap) + 5))
    try:
        queue.put(("ok", target(*args)))
    except Exception as exc:        # reported in the table, not hidden: the type and text
        queue.put(("error", f"{type(exc).__name__}: {str(exc)[:300]}"))


def in_child(target, args, cpu_cap: float):
    """``target(*args)`` in a fresh process under a CPU cap: ("ok", result), ("error", text) or ("cap", None)."""
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child, args=(target, args, queue, cpu_cap), daemon=True)
    proc.start()
    while True:
        try:
            return queue.get(timeout=5.0)
        except Exception:
            if not proc.is_alive():
                try:
                    return queue.get(timeout=1.0)
                except Exception:
                    return ("cap", None)
        finally:
            if not proc.is_alive():
                proc.join()


# -- table -------------------------------------------------------------------------------------------------------
def _ratio(true: float, est: float) -> str:
    if est == 0.0:
        return f"{true:.1e} / 0 (-)"
    return f"{true:.1e} / {est:.1e} ({true / est:.2f})"


def flags(row: dict) -> list[str]:
    """What breaks the contract: true > estimate or true < estimate / 10 (states, multipliers), met but not."""
    out = []
    est, tru, tol = row["estimate"], row["true"], row["tolerance"]
    for q in ("states", "multipliers"):
        if tru[q] > est[q]:
            out.append(f"{q}: true {tru[q]:.2e} > estimate {est[q]:.2e}")
        elif tru[q] < est[q] / 10:
            out.append(f"{q}: true {tru[q]:.2e} < estimate / 10 ({est[q]:.2e})")
    covered = sum(hi - lo for lo, hi in row["windows"])
    if not row.get("reference_jumps", True) and row["windows"] and tru["multipliers_all"] > max(tol, est["multipliers"]):
        out.append(f"multipliers: jump windows over {covered:.0%} of the horizon where the reference does not jump; "
                   f"true error there {tru['multipliers_all']:.2e} > tolerance and estimate ({est['multipliers']:.2e}), "
                   f"unseen by the estimate")
    if row["met"] and max(tru["states"], tru["multipliers"]) > tol:
        out.append(f"met claimed, true errors states {tru['states']:.2e} multipliers {tru['multipliers']:.2e} > {tol:g}")
    return out


def cheapest(rows: list[dict], tol: float, free_time: bool, with_inputs: bool = True) -> dict | None:
    ok = [r for r in rows if "true" in r and r["true"]["states"] <= tol and r["true"]["multipliers"] <= tol
          and (not with_inputs or r["true"]["inputs"] <= tol) and (not free_time or r["true"]["t_final"] <= tol)]
    return min(ok, key=lambda r: r["cpu"]) if ok else None


def table(name: str, rows: list[dict], fixed: list[dict] | None, free_time: bool) -> str:
    lines = [f"### {name}", "",
             "| tolerance | met | refinements (solves), IPOPT iterations | final mesh | states true / estimate (ratio) "
             "| multipliers true / estimate (ratio) [all t > 0] | inputs true / estimate (ratio) [all t > 0] "
             "| final time true / estimate | objective rel. error | CPU / wall (s) | cheapest uniform Radau meeting it on states and multipliers (and final time) (CPU s) "
             "| refined / fixed CPU |", "|" + "---|" * 12]
    for row in rows:
        tol = row["tolerance"]
        if row.get("status") != "ok":
            lines.append(f"| {tol:g} | {row['status']} |" + " |" * 10)
            continue
        est, tru = row["estimate"], row["true"]
        mesh = (f"{row['intervals']} intervals, degrees {row['degrees'][0]}-{row['degrees'][1]}, {row['points']} points; "
                f"widths {row['widths'][0]:.2g}-{row['widths'][1]:.2g} s; shortest at {row['short']} s")
        if row["switch_gap"]:
            mesh += "; nearest mesh point to the switch(es): " + ", ".join(
                f"{g:.1e} s from {s:.4g}" for s, g in row["switch_gap"].items())
        if row["windows"]:
            mesh += f"; jump windows ({row.get('windows_from', 'record')}; s, left out of the multipliers' and inputs' estimate): " + ", ".join(
                f"{lo * row['t_final']:.5g}-{hi * row['t_final']:.5g}" for lo, hi in row["windows"])
        tf = f"{tru['t_final']:.1e} / {est.get('t_final', 0.0):.1e}" if free_time else "-"
        best = cheapest(fixed, tol, free_time, with_inputs=False) if fixed else None
        best_in = cheapest(fixed, tol, free_time) if fixed else None
        if fixed is None:
            fx, ratio = "(not run)", "-"
        else:
            def label(r):
                return f"radau{r['degree']} N={r['intervals']} ({r['points']} points): {r['cpu']:.2f}" if r else "none in the sweep"
            fx = label(best) + ("" if best_in is best else f"; with the inputs too: {label(best_in)}")
            ratio = f"{row['cpu'] / best['cpu']:.1f}" if best else "-"
        met = ("yes" if row["met"] else "**no**") + f": {row['message'][:400]}"
        lines.append(
            f"| {tol:g} | {met} | {row['refinements']} ({row['solves']}), {row['iterations']} | {mesh} "
            f"| {_ratio(tru['states'], est['states'])} "
            f"| {_ratio(tru['multipliers'], est['multipliers'])} [{tru['multipliers_all']:.1e}] "
            f"| {_ratio(tru['inputs'], est['inputs'])} [{tru['inputs_all']:.1e}] | {tf} | {tru['objective']:.1e} "
            f"| {row['cpu']:.1f} / {row['wall']:.1f} | {fx} | {ratio} |")
    return "\n".join(lines)


def fixed_table(rows: list[dict], free_time: bool) -> str:
    lines = ["| uniform Radau | points | states | multipliers [all t > 0] | inputs [all t > 0] | final time | CPU / wall (s) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if "true" not in r:
            lines.append(f"| radau{r['degree']} N={r['intervals']} | | {r['status']} | | | | {r['cpu']:.2f} |")
            continue
        t = r["true"]
        lines.append(f"| radau{r['degree']} N={r['intervals']} | {r['points']} | {t['states']:.1e} | "
                     f"{t['multipliers']:.1e} [{t['multipliers_all']:.1e}] | {t['inputs']:.1e} [{t['inputs_all']:.1e}] | "
                     + (f"{t['t_final']:.1e}" if free_time else "-") + f" | {r['cpu']:.2f} / {r['wall']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tolerances", type=float, nargs="+", default=[1e-3, 1e-4, 1e-5, 1e-6])
    parser.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=list(PROBLEMS))
    parser.add_argument("--cpu-cap", type=float, default=120.0, help="CPU seconds per refined solve (RLIMIT_CPU)")
    parser.add_argument("--no-fixed", action="store_true", help="skip the uniform-mesh sweep")
    parser.add_argument("--out", type=Path, default=None, help="markdown file to write (default: print only)")
    parser.add_argument("--fixed-degrees", type=int, nargs="+", default=list(FIXED_DEGREES))
    parser.add_argument("--fixed-intervals", type=int, nargs="+", default=list(FIXED_INTERVALS))
    parser.add_argument("--experiment", choices=["clean-effect"], default=None,
                        help="rebind the refinement's switch detection in the children (clean_effect_experiment); "
                             "sections are named '<problem> [clean-effect]'")
    parser.add_argument("--notes", type=Path, default=None, help="markdown put before the tables (else kept)")
    parser.add_argument("--table-only", action="store_true", help="only put --notes into --out, run nothing")
    args = parser.parse_args(argv)
    if args.table_only:
        if args.out is None:
            parser.error("--table-only needs --out")
        write(args.out, "", {}, args.notes.read_text() if args.notes else None)
        return
    sections = [f"Command: `python scripts/refinement_holdouts.py --tolerances {' '.join(f'{t:g}' for t in args.tolerances)} "
                f"--problems {' '.join(args.problems)} --cpu-cap {args.cpu_cap:g}{' --no-fixed' if args.no_fixed else ''}"
                f"{' --experiment ' + args.experiment if args.experiment else ''}"
                f"{'' if args.no_fixed or tuple(args.fixed_degrees) == FIXED_DEGREES else ' --fixed-degrees ' + ' '.join(map(str, args.fixed_degrees))}"
                f"{'' if args.no_fixed or tuple(args.fixed_intervals) == FIXED_INTERVALS else ' --fixed-intervals ' + ' '.join(map(str, args.fixed_intervals))}`; "
                f"load average at start {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
                f"library {Path(oc.__file__).parent}."]
    for name in args.problems:
        ref = PROBLEMS[name][1]()
        rows = []
        for tol in args.tolerances:
            status, result = in_child(refined_run, (name, tol, args.experiment), args.cpu_cap)
            row = result if status == "ok" else {"tolerance": tol}
            row["status"] = status if status != "cap" else f"not finished within {args.cpu_cap:g} s CPU"
            if status == "error":
                row["status"] = f"error: {result}"
            rows.append(row)
            print(name, tol, row["status"], "" if status != "ok" else
                  f"met {row['met']} points {row['points']} est {row['estimate']} true "
                  f"{ {k: v for k, v in row['true'].items() if not k.endswith('_at')} } cpu {row['cpu']:.1f}", flush=True)
        fixed = None
        if not args.no_fixed:
            status, fixed = in_child(fixed_sweep, (name, tuple(args.fixed_degrees), tuple(args.fixed_intervals)),
                                     20 * args.cpu_cap)
            if status != "ok":
                print(name, "fixed sweep:", status, fixed)
                fixed = None
        part = [table(name if args.experiment is None else f"{name} [{args.experiment}]", rows, fixed, ref.free_time), ""]
        for row in rows:
            if row.get("status") == "ok":
                for f in flags(row):
                    part.append(f"- **flag** {name} at {row['tolerance']:g}: {f} "
                                f"(`python scripts/refinement_holdouts.py --problems {name} --tolerances {row['tolerance']:g} --no-fixed"
                                f"{' --experiment ' + args.experiment if args.experiment else ''}`)")
                tru = row["true"]
                part.append(f"- {name} at {row['tolerance']:g}: largest true errors at t = {tru['states_at']:.4g} s (states), "
                            f"{tru['multipliers_at']:.4g} s (multipliers), {tru['inputs_at']:.4g} s (inputs); "
                            f"normal load off M g by {row['normal_force_error']:.1e} N; per mesh (points, iterations, "
                            f"companion iterations, estimate states / multipliers): "
                            + "; ".join(f"{p}, {i}, {c}, " + (f"{e['states']:.1e} / {e['multipliers']:.1e}"
                                                               if e.get("states") is not None else "not solved")
                                        for p, i, c, e in row["per_mesh"])
                            + "; switches located on the final solution (kind, bound, at s, bracket s, effect): "
                            + ("; ".join(f"{k}, {q}, {a:.5g}, {b[0]:.5g}-{b[1]:.5g}, {e:.1e}" for k, q, a, b, e in row["located"])
                               or "none"))
        if fixed:
            part += ["", "Uniform meshes (cold):", "", fixed_table(fixed, ref.free_time)]
        sections.append("\n".join(part))
        print(part[0], flush=True)
        if args.out:
            names = [n if args.experiment is None else f"{n} [{args.experiment}]" for n in args.problems]
            write(args.out, sections[0], dict(zip(names, sections[1:])),
                  args.notes.read_text() if args.notes else None)


def write(out: Path, header: str, parts: dict[str, str], notes: str | None = None) -> None:
    """Write ``out``: the problems' sections re-run here replace their own, the others' are kept (each
    section, "### name" to the next, with the command line that made it); ``notes`` (markdown) replace the
    text before the first section, else it is kept."""
    kept: dict[str, str] = {}
    preamble = ""
    if out.exists():
        text = out.read_text()
        preamble = text.split("\n### ")[0].split("\n", 1)[1].strip() if "\n" in text else ""
        for chunk in text.split("\n### ")[1:]:
            name = chunk.split("\n", 1)[0].strip()
            kept[name] = "### " + chunk.strip()
    for name, part in parts.items():
        kept[name] = part.strip() + "\n\n" + header
    order = [n for n in PROBLEMS if n in kept] + [n for n in kept if n not in PROBLEMS]
    out.parent.mkdir(parents=True, exist_ok=True)
    preamble = notes.strip() if notes is not None else preamble
    out.write_text("# Refinement holdouts (issue 19)\n\n" + (preamble + "\n\n" if preamble else "")
                   + "\n\n".join(kept[n] for n in order) + "\n")


if __name__ == "__main__":
    main()
