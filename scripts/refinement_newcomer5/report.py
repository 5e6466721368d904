"""Tables of results.jsonl (python report.py), markdown to stdout."""
import json, os

HERE = os.path.dirname(os.path.abspath(__file__))
recs = [json.loads(l) for l in open(os.path.join(HERE, "results.jsonl"))]
f = lambda v, fmt=".1e": "-" if v is None else format(v, fmt)
NAMES = {"dpend": "1. double pendulum, effort + shoulder load (default start: Radau 5 x 10)", "dpend_r3n40": "1b. the same, refined from the mesh Radau 3 x 40 (solve(oc.Radau(40, degree=3), tolerance=tol))", "pend": "2. pendulum, hinge force bounded (arc)",
         "rp": "3. RP robot, arm angle bounded (arc)", "ft": "4. rod, free final time, time + effort + terminal miss"}
for p in ("dpend", "dpend_r3n40", "pend", "rp", "ft"):
    rs = [r for r in recs if r["problem"] == p]
    if not rs:
        continue
    acc = next((r["ref_accuracy"] for r in rs if "ref_accuracy" in r), {})
    print(f"\n### {NAMES[p]}\n")
    print(f"Reference: Radau {acc.get('degree')} on {acc.get('N')} intervals, coarse vs fine: states "
          f"{f(acc.get('states_coarse_vs_fine'))}, loads {f(acc.get('loads_coarse_vs_fine_rel_peak'))} of the peak "
          f"{f(acc.get('peak_load'), '.4g')} N; objective {acc.get('objective_fine')!r} (coarse {acc.get('objective_coarse')!r})"
          + (f"; junctions (fractions of T) {[round(v, 8) for v in acc.get('junctions_fine')]}" if acc.get('junctions_fine') else "")
          + (f"; T {acc.get('T_fine')!r} (coarse {acc.get('T_coarse')!r})" if p == "ft" else "") + "\n")
    print("| tol | met | points | meshes | CPU s | estimate states / mult | true states / mult | true/estimate states / mult | objective - ref | where the true max is (t s, channel) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        if "crash" in r:
            print(f"| {r['tol']} | **crash** | | | | | | | | {r['crash'][:200]} |")
            continue
        e, t, q = r["estimate"], r["true"], r["ratio"]
        w = t.get("where", {})
        ws = "; ".join(f"{w[k][1]} @ {w[k][0]:.4f}" for k in ("states", "multipliers") if k in w)
        def mark(x):
            if x is None:
                return "-"
            s = f"{x:.2f}"
            return f"**{s}**" if (r["met"] and (x > 1 or x < 0.1)) else s
        print(f"| {r['tol']} | {'yes' if r['met'] else '**NO**'} | {r['points']} | {r.get('solves')} | {r['cpu']:.1f} "
              f"| {f(e.get('states'))} / {f(e.get('multipliers'))} | {f(t['states'])} / {f(t['multipliers'])} "
              f"| {mark(q['states'])} / {mark(q['multipliers'])} | {r['objective'] - r['objective_ref']:+.1e} | {ws} |")
    print()
    for r in rs:
        extra = ""
        if "path" in r:
            extra += f" Hinge force: max at the points {r['path']['max_F_points']:.6f} N, interpolated {r['path']['max_F_interp']:.6f} N (bound {r['path']['F_max']})."
        if "bound" in r:
            extra += f" Arm angle: max at the points {r['bound']['max_points']:.8f}, interpolated {r['bound']['max_interp']:.8f} (bound {r['bound']['psi_max']})."
        if r.get("true_against_each") and len(r["true_against_each"]) > 1:
            extra += " Against each reference: " + "; ".join(f"{k} (J {v['objective_ref']:.6f}): states {v['states']:.1e}, mult {v['multipliers']:.1e}" for k, v in r["true_against_each"].items()) + "."
        if p == "ft" and "true" in r:
            extra += f" T_lib - T_ref {r['true']['T_lib'] - r['T_ref']:+.1e} s (estimate t_final {f(r['estimate'].get('t_final'))})."
        if r.get("estimate", {}).get("inputs") is not None:
            extra += f" Inputs' estimate {f(r['estimate']['inputs'])}."
        if r.get("bounds_passed_between_points"):
            extra += f" bounds_passed_between_points: {r['bounds_passed_between_points']}."
        print(f"- {r['tol']}: \"{r.get('message', r.get('crash'))}\"{extra}")
