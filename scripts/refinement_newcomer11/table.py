"""Markdown tables from runs_NAME.jsonl:  python table.py [NAME ...]"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def f(x, p=2):
    return "-" if x is None else (f"{x:.{p}e}" if isinstance(x, float) else str(x))


for name in sys.argv[1:] or ["arm_sat", "cart_force", "rod_lower"]:
    p = HERE / f"runs_{name}.jsonl"
    if not p.exists():
        continue
    print(f"\n### {name}\n")
    print("| tol | met | points | CPU s (total_cpu_s) | est s / m | true s / m | ratio s / m | junctions lib | junctions ref | max junction diff (s) | J lib - J ref |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for l in p.read_text().splitlines():
        r = json.loads(l)
        if r.get("error"):
            print(f"| {r['tol']:.0e} | ERROR {r['error']} | | | | | | | | | |")
            continue
        rs, rm = r.get("ratio_states"), r.get("ratio_multipliers")
        lj = ", ".join(f"{x:.9f}" for x in r.get("lib_junctions") or [])
        rj = ", ".join(f"{x:.9f}" for x in r.get("ref_junctions") or [])
        dJ = (r["objective"] - r["ref_objective"]) if r.get("objective") is not None else None
        print(f"| {r['tol']:.0e} | {r['met']} | {r['points']} | {r['cpu_s']:.2f} ({f(r.get('total_cpu_s'))}) | "
              f"{f(r['est_states'])} / {f(r['est_mult'])} | {f(r['true_states'])} / {f(r['true_mult'])} | "
              f"{rs:.2f} / {rm:.2f} | {lj} | {rj} | {f(r.get('junction_err'))} | {f(dJ)} |")
    for l in p.read_text().splitlines():
        r = json.loads(l)
        if not r.get("error"):
            print(f"\n- {r['tol']:.0e}: {r.get('message')}; worst state {r.get('worst_state')}, worst multiplier "
                  f"{r.get('worst_mult')} at t = {r.get('worst_mult_t')}; input_arcs: "
                  + "; ".join(f"{a.get('quantity')} = {a.get('value')} on [{a.get('start')}, {a.get('end')}]"
                              for a in (r.get('input_arcs') or [])))
