"""Markdown tables of the report from runs_*.jsonl and uniform_*.jsonl.

    python table.py [NAME ...]        # default: every runs_*.jsonl here
    python table.py --uniform [NAME ...]   # one compact line per problem of the uniform sweeps
"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def f(x, spec=".1e"):
    return "-" if x is None else format(x, spec)


def ratio(t, e):
    if t is None or e is None or e == 0:
        return "-"
    r = t / e
    s = f"{r:.2f}"
    return f"**{s}**" if (r > 1 or r < 0.1) else s


def uniform_rows(name):
    p = HERE / f"uniform_{name}.jsonl"
    if not p.exists():
        return []
    return [json.loads(l) for l in p.read_text().splitlines() if l.strip()]


def cheapest(rows, st, mu):
    ok = [r for r in rows if not r.get("killed") and r["states"] <= st and r["multipliers"] <= mu]
    return min(ok, key=lambda r: (r["points"], r["cpu"])) if ok else None     # the smallest mesh (CPU is noise-level)


def runs_table(name):
    rows = [json.loads(l) for l in (HERE / f"runs_{name}.jsonl").read_text().splitlines() if l.strip()]
    uni = uniform_rows(name)
    print(f"\n### {name}\n")
    print("| tol | met | intervals / points | CPU s (wall s) | estimate states / multipliers | true states / multipliers "
          "(dense grid) | true / estimate states / multipliers | inputs true / est | J - J_ref | smallest uniform Radau "
          "meeting tol in truth: N x deg, CPU s | smallest uniform as accurate as this run: N x deg, CPU s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        tol = r["tol"]
        extra = (f" (max_refinements={r['maxref']})" if r.get("maxref") else "") + (
            f" (from Radau {r['start'].replace(',', ' x deg ')})" if r.get("start") else "")
        if r.get("killed"):
            print(f"| {tol:g}{extra} | killed (rc {r['returncode']}) | - | >{r['cap']:.0f} | - | - | - | - | - | - | - |")
            continue
        if r.get("exception"):
            print(f"| {tol:g}{extra} | EXCEPTION | - | {r['cpu']:.1f} | {r['exception'][:100]} | - | - | - | - | - | - |")
            continue
        e, t = r["estimate"], r["true"]["dense"]
        u1 = cheapest(uni, tol, tol)
        u2 = cheapest(uni, t["states"], t["multipliers"])
        us = lambda u: "-" if u is None else f"{u['N']} x {u['deg']}, {u['cpu']:.2f}"
        print(f"| {tol:g}{extra} | {r['met']} | {r['intervals']} / {r['points']} | {r['cpu']:.1f} ({r['wall']:.1f}) | "
              f"{f(e['states'])} / {f(e['multipliers'])} | {f(t['states'])} / {f(t['multipliers'])} | "
              f"{ratio(t['states'], e['states'])} / {ratio(t['multipliers'], e['multipliers'])} | "
              f"{ratio(t['inputs'], e.get('inputs'))} | {r['objective'] - r['objective_ref']:+.1e} | {us(u1)} | {us(u2)} |")
    print("\nWhere the true errors lie (dense grid) and the messages (first 300 characters):\n")
    for r in rows:
        if r.get("killed") or r.get("exception"):
            continue
        t = r["true"]["dense"]
        tp = r["true"]["points"]
        extra = (f" max_refinements={r['maxref']}" if r.get("maxref") else "") + (
            f" from Radau {r['start'].replace(',', ' x deg ')}" if r.get("start") else "")
        print(f"- {r['tol']:g}{extra}: states at {t['states_at'][0]} t={t['states_at'][1]:.4f}, multipliers at "
              f"{t['multipliers_at'][0]} t={t['multipliers_at'][1]:.4f} (at the collocation points only: "
              f"{tp['states']:.1e} / {tp['multipliers']:.1e}); load_scale {r['load_scale']:.3f}; refinements "
              f"{len(r['history']) - 1}; \"{r['message'][:300]}\"")


def uniform_table(name):
    uni = uniform_rows(name)
    if not uni:
        return
    print(f"\n#### uniform meshes, {name}\n")
    print("| N x deg | points | CPU s | true states | true multipliers (of the reference's largest |lambda|) | J |")
    print("|---|---|---|---|---|---|")
    for u in uni:
        if u.get("killed"):
            print(f"| {' '.join(u['args'][2:])} | killed | - | - | - | - |")
            continue
        print(f"| {u['N']} x {u['deg']} | {u['points']} | {u['cpu']:.2f} | {u['states']:.1e} | {u['multipliers']:.1e} |"
              f" {u['objective']:.10f} |")




def uniform_compact(names, Ns=(20, 40, 80, 100, 160, 200, 400, 800)):
    """One line per problem: uniform Radau(N, 5) true states / multipliers error and CPU s."""
    print("\n| problem | " + " | ".join(f"N = {n}" for n in Ns) + " |")
    print("|---" * (len(Ns) + 1) + "|")
    for name in names:
        rows = {r["N"]: r for r in uniform_rows(name) if not r.get("killed")}
        cells = [f"{rows[n]['states']:.0e} / {rows[n]['multipliers']:.0e}, {rows[n]['cpu']:.2f} s" if n in rows else ""
                 for n in Ns]
        print(f"| `{name}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--uniform":
        uniform_compact(args[1:] or sorted(p.stem[8:] for p in HERE.glob("uniform_*.jsonl")))
    else:
        for n in args or sorted(p.stem[5:] for p in HERE.glob("runs_*.jsonl")):
            runs_table(n)
            uniform_table(n)
