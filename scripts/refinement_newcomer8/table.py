"""Markdown tables from runs_<problem>.jsonl (written by ``python nc8.py all <problem>``).

    python table.py [problem ...]
"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def f(x, fmt=".1e"):
    return "-" if x is None else format(x, fmt)


def main(names):
    for name in names:
        p = HERE / f"runs_{name}.jsonl"
        if not p.exists():
            continue
        print(f"\n**{name}**\n")
        print("| tol | met | points (intervals) | CPU s | estimate states / multipliers | true states / multipliers | "
              "ratio states / multipliers | flags |")
        print("|---|---|---|---|---|---|---|---|")
        for line in p.read_text().splitlines():
            r = json.loads(line)
            if "exception" in r or "killed" in r:
                what = r.get("exception") or f"killed (rc {r.get('killed')}): CPU cap {r.get('cap_s', 120)} s reached"
                print(f"| {r['tol']:g} | {what[:120]} | | {f(r.get('cpu_s'), '.1f')} | | | | exception |")
                continue
            es, em, ts, tm = r["est_states"], r["est_multipliers"], r["true_states"], r["true_multipliers"]
            rs = ts / es if es else None
            rm = tm / em if (em and tm is not None) else None
            flags = []
            if r["met"]:
                for lab, q in (("states", rs), ("multipliers", rm)):
                    if q is not None and q > 1:
                        flags.append(f"{lab} true > estimate")
                    if q is not None and q < 0.1:
                        flags.append(f"{lab} true < estimate/10")
            print(f"| {r['tol']:g}{' (cap %s s)' % r['cap_s'] if r.get('cap_s', 120) != 120 else ''} | {r['met']} | {r['points']} ({r['intervals']}) | {r['cpu_s']:.1f} | {f(es)} / {f(em)} | "
                  f"{f(ts)} ({r['worst_state']}) / {f(tm)} ({r['worst_multiplier']}) | {f(rs, '.2f')} / {f(rm, '.2f')} | "
                  f"{'; '.join(flags)} |")
        for line in p.read_text().splitlines():
            r = json.loads(line)
            if not r.get("met"):
                print(f"\n- {r['tol']:g}: {r.get('message') or r.get('exception') or r.get('stderr_tail', '')[-300:]}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["pend", "pend_max", "speed", "bd12", "vert"])
