import json, os, sys
recs = [json.loads(l) for l in open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "results.jsonl"))]
f = lambda v, fmt=".1e": "-" if v is None else format(v, fmt)
for p in ("fourbar", "dpend", "cartpole", "arm"):
    rs = [r for r in recs if r["problem"] == p]
    if not rs: continue
    print(f"\n### {p}  (coords {rs[0].get('coordinates')}, ref accuracy states {f(rs[0].get('ref_accuracy',{}).get('states_coarse_vs_fine'))}, mult {f(rs[0].get('ref_accuracy',{}).get('multipliers_coarse_vs_fine_rel_peak'))})")
    print("| tol | met | points | CPU s | est s / m | true s / m | ratio s / m | obj - ref | where true max (s; m) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        if "crash" in r:
            print(f"| {r['tol']} | crash | | | | | | | {r['crash'][:120]} |"); continue
        e, t, q = r["estimate"], r["true"], r["ratio"]
        w = t.get("where", {})
        ws = "; ".join(f"{w[k][1]} @ {w[k][0]:.4g}" for k in ("states", "multipliers") if k in w)
        print(f"| {r['tol']} | {'yes' if r['met'] else 'NO'} | {r['points']} | {r['cpu']:.1f} | {f(e.get('states'))} / {f(e.get('multipliers'))} "
              f"| {f(t['states'])} / {f(t['multipliers'])} | {f(q['states'], '.2f')} / {f(q['multipliers'], '.2f')} "
              f"| {r['objective'] - r['objective_ref']:.1e} | {ws} |")
    for r in rs:
        extra = ""
        if "bound" in r: extra += f" bound {r['bound']}"
        if "contact" in r: extra += f" contact {r['contact']}"
        if p == "arm" and "true" in r: extra += f" T_lib {r['true']['T_lib']:.10f} T_ref {r['T_ref']:.10f}"
        print(f"- {r['tol']}: {r.get('message', r.get('crash'))}{extra}")
