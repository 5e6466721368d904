"""Markdown tables of the runs_*.jsonl files: python table.py > tables.md"""
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
f = lambda x: "-" if x is None else (f"{x:.2g}" if isinstance(x, float) else str(x))


def ratio(t, e):
    return "-" if not e else f"{t / e:.2f}"


print("| run | tol | met | points (intervals) | refinements | CPU s | T - T_ref | states: true / est (ratio) | "
      "T: true / est | multipliers: true / est (ratio) | inputs: true / est (ratio) | objective - ref |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for p in sorted(HERE.glob("runs_*.jsonl")):
    for l in p.read_text().splitlines():
        r = json.loads(l)
        if r.get("met") is None:
            print(f"| {p.stem[5:]} | {r['tol']:g} | ERROR {r.get('error')} |"); continue
        print(f"| {p.stem[5:]} | {r['tol']:g} | {'yes' if r['met'] else '**no**'} | {r['points']} ({r['intervals']}) | "
              f"{r['refinements'] - 1} | {r['cpu_s']:.1f} | {r['T_sol'] - r['T_ref']:.1e} | "
              f"{f(r['true_states'])} / {f(r['est_states'])} ({ratio(r['true_states'], r['est_states'])}) | "
              f"{f(r['true_T'])} / {f(r['est_t_final'])} | "
              f"{f(r['true_mult'])} / {f(r['est_mult'])} ({ratio(r['true_mult'], r['est_mult'])}) | "
              f"{f(r['true_inputs'])} / {f(r['est_inputs'])} ({ratio(r['true_inputs'], r['est_inputs'])}) | "
              f"{r['objective'] - r['ref_objective']:.1e} |")
