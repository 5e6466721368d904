"""Tables of the report from runs_*.jsonl and uniform_*.jsonl:  python table.py > tables.md"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def f(x, p=2):
    return "-" if x is None else (f"{x:.{p}e}" if isinstance(x, float) else str(x))


def ratio(a, b):
    return "-" if a is None or not b else f"{a / b:.2f}"


names = sys.argv[1:] or ["vehicle", "vehicle_free", "spring", "fivebar_free", "fivebar"]
for n in names:
    p = HERE / f"runs_{n}.jsonl"
    if not p.exists():
        continue
    print(f"\n### {n}\n")
    print("| tol | met | points (intervals) | solves | total_time_s | est states | true states | ratio | est mult | "
          "true mult | ratio | true mult w/o t=0,T | est inputs | true inputs | message |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for line in p.read_text().splitlines():
        r = json.loads(line)
        if "exception" in r or "killed" in r and r.get("met") is None:
            print(f"| {r['tol']:g} | {r.get('exception') or r.get('killed')} |")
            continue
        e = r.get("estimate") or {}
        msg = (r.get("message") or "").replace("|", "/")
        print(f"| {r['tol']:g} | {r['met']} | {r['points']} ({r['intervals']}) | {r['solves']} | {r['total_time_s']:.2f} | "
              f"{f(e.get('states'))} | {f(r['true_states'])} | {ratio(r['true_states'], e.get('states'))} | "
              f"{f(e.get('multipliers'))} | {f(r['true_multipliers'])} | {ratio(r['true_multipliers'], e.get('multipliers'))} | "
              f"{f(r.get('true_multipliers_inner'))} | {f(e.get('inputs'))} | {f(r['true_inputs'])} | {msg[:300]} |")
    u = HERE / f"uniform_{n}.jsonl"
    if u.exists():
        print(f"\nFixed Radau meshes ({n}):\n")
        print("| N | degree | points | cpu_s | true states | true mult | true inputs |")
        print("|---|---|---|---|---|---|---|")
        for line in u.read_text().splitlines():
            r = json.loads(line)
            print(f"| {r['N']} | {r['degree']} | {r.get('points')} | {f(r.get('cpu_s'))} | {f(r.get('true_states'))} | "
                  f"{f(r.get('true_multipliers'))} | {f(r.get('true_inputs'))} |")
