"""Markdown tables of the runs_*.jsonl files: python table.py > tables.md"""
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
f = lambda x: "-" if x is None else (f"{x:.2g}" if isinstance(x, float) else str(x))
print("| file | tol | met | points (intervals) | refinements | total_time_s | est states | true states | ratio | "
      "est mult | true mult outside windows (all) | ratio outside windows | objective - ref |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for p in sorted(HERE.glob("runs_*.jsonl")):
    if p.name == "runs_fuel_first.jsonl":
        continue
    for l in p.read_text().splitlines():
        r = json.loads(l)
        if r.get("met") is None:
            print(f"| {p.stem[5:]} | {r['tol']:g} | ERROR {r.get('error')} |"); continue
        print(f"| {p.stem[5:]} | {r['tol']:g} | {r['met']} | {r['points']} ({r['intervals']}) | {r['refinements'] - 1} | "
              f"{r['total_time_s']:.2f} | {f(r['est_states'])} | {f(r['true_states'])} | {f(r['ratio_states'])} | "
              f"{f(r['est_mult'])} | {f(r['true_mult_outside_windows'])} ({f(r['true_mult'])}) | "
              f"{f(r['ratio_mult_outside_windows'])} | {r['objective'] - r['ref_objective']:.1e} |")
