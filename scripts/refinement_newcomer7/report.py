"""Tables of results.jsonl (python report.py [FILE]), markdown to stdout (newcomer 6's report.py, check 7's names)."""
import json, os, sys

HERE = os.path.dirname(os.path.abspath(__file__))
fn = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "results.jsonl")
recs = [json.loads(l) for l in open(fn)]
f = lambda v, fmt=".1e": "-" if v is None else format(v, fmt)
NAMES = {"urdf_arm@r3n40": "1. URDF two-link arm (arm2.urdf, oc.load_urdf), rest to rest, least effort, |shoulder.tau| <= 4.5 (one arc), refined from Radau 3 x 40",
         "urdf_arm": "1b. the same from the default start (solve(tolerance=tol))",
         "load_arm": "2. two-link arm by hand, min effort + 0.05 minimize_load_effort([elbow.v1, elbow.v2]), default start (the optimum it finds, objective 31.224)",
         "load_arm@r5n40": "2b. the same refined from Radau 5 x 40 (the better optimum, objective 13.946)"}
for p in NAMES:
    rs = [r for r in recs if r["problem"] == p]
    if not rs:
        continue
    acc = next((r["ref_accuracy"] for r in rs if "ref_accuracy" in r), {})
    print(f"\n### {NAMES[p]}\n")
    print(f"Reference: Radau {acc.get('degree')} on {acc.get('N')} intervals, coarse vs fine on a dense grid: states "
          f"{f(acc.get('states_coarse_vs_fine'))}, loads {f(acc.get('loads_coarse_vs_fine_rel_peak'))} of the peak "
          f"{f(acc.get('peak_load'), '.4g')} N; objective {acc.get('objective_fine')!r} (coarse {acc.get('objective_coarse')!r})"
          + (f"; junctions (fractions of T) {[round(v, 8) for v in acc.get('junctions_fine')]}" if acc.get('junctions_fine') else "") + "\n")
    print("| tol | met | points | intervals | meshes (points per solve) | CPU s | estimate states / mult | true states / mult (dense) | true/estimate states / mult | true at points states / mult | objective - ref | where the true max is (t s, quantity) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        if "crash" in r:
            print(f"| {r['tol']} | **crash** | | | | {f(r.get('cpu'), '.1f')} | | | | | | {r['crash'][:300]} |")
            continue
        e, t, q, tp = r["estimate"], r["true"], r["ratio"], r["true_at_points"]
        w = t.get("where", {})
        ws = "; ".join(f"{k[:5]}: {w[k][1]} @ {w[k][0]:.4f}" for k in ("states", "multipliers") if k in w)

        def mark(x):
            if x is None:
                return "-"
            s = f"{x:.2f}"
            return f"**{s}**" if (r["met"] and (x > 1 or x < 0.1)) else s
        print(f"| {r['tol']} | {'yes' if r['met'] else '**NO**'} | {r['points']} | {r['intervals']} | {r.get('meshes')} | {r['cpu']:.1f} "
              f"| {f(e.get('states'))} / {f(e.get('multipliers'))} | {f(t['states'])} / {f(t['multipliers'])} "
              f"| {mark(q['states'])} / {mark(q['multipliers'])} | {f(tp['states'])} / {f(tp['multipliers'])} "
              f"| {r['objective'] - r['objective_ref']:+.1e} | {ws} |")
    print()
    for r in rs:
        extra = ""
        if r.get("estimate", {}).get("inputs") is not None:
            extra += f" Inputs' estimate {f(r['estimate']['inputs'])}."
        if r.get("switches_located"):
            extra += " switches_located (kind @ t s): " + ", ".join(f"{sw.get('kind')} {sw.get('quantity')} @ {sw.get('t'):.6f}" for sw in r["switches_located"]) + "."
        if r.get("bounds_passed_between_points"):
            extra += f" bounds_passed_between_points: {r['bounds_passed_between_points']}."
        if r.get("min_interval") is not None:
            extra += f" Shortest interval {r['min_interval']:.2e} s."
        print(f"- {r['tol']}: \"{r.get('message', r.get('crash'))}\"{extra}")
