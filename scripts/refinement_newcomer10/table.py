"""Markdown tables of the report from runs_NAME.jsonl and uniform_NAME.jsonl.

    python table.py > tables.md
"""
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
PROBLEMS = ["stiff200", "stiff2000", "chain3", "slew_ball", "slew_ball_bound", "mintime"]


def g(x, f="{:.1e}"):
    return "-" if x is None else f.format(x)


def rows(name):
    p = HERE / f"runs_{name}.jsonl"
    if not p.exists():
        return []
    seen, out = set(), []
    for line in p.read_text().splitlines():
        r = json.loads(line)
        key = (r["tol"], r.get("max_refinements"))
        if key in seen:       # a repeated run (same tolerance) is listed once, the first
            continue
        seen.add(key)
        out.append(r)
    return out


def uniform(name):
    p = HERE / f"uniform_{name}.jsonl"
    return [json.loads(x) for x in p.read_text().splitlines()] if p.exists() else []


def main():
    summary = {"met": 0, "not met": 0, "exception": 0, "killed": 0}
    for name in PROBLEMS:
        rs = rows(name)
        if not rs:
            continue
        print(f"\n### {name}\n")
        print("| tol | met | points (intervals) of the returned solution | CPU s | estimate states / multipliers | true states / multipliers | "
              "ratio states / multipliers | where the max true error is | inputs est / true |")
        print("|---|---|---|---|---|---|---|---|---|")
        for r in rs:
            if "exception" in r or "killed" in r:
                summary["exception" if "exception" in r else "killed"] += 1
                print(f"| {r['tol']:g} | {r.get('exception') or r.get('killed')} | | | | | | | |")
                continue
            summary["met" if r["met"] else "not met"] += 1
            e = r["estimate"] or {}
            es, em = e.get("states"), e.get("multipliers")
            ts, tm = r["true_states"], r.get("true_multipliers")
            rs_ = ts / es if es else None
            rm = tm / em if (em and tm is not None and em > 1e-10) else None
            rm_s = g(rm, "{:.2f}") if rm is not None else ("floor (est 1e-10, loads 0)" if em and em <= 1e-10 else "-")
            flag = lambda x: "**" if x is not None and r["met"] and (x > 1 or x < 0.1) else ""   # noqa: E731
            where = f"{r['worst_state']} @ {r['worst_state_t']:.4f} s; {r.get('worst_multiplier') or ''}" + (
                f" @ {r['worst_multiplier_t']:.4f} s" if r.get("worst_multiplier_t") is not None else "")
            extra = ""
            if name.startswith("slew"):
                extra = f" (quat {g(r.get('true_quat'))}, R {g(r.get('true_R'))}, omega {g(r.get('true_omega'))})"
            pts = f"{r['points']} ({r['intervals']})"
            if r.get("returned_points"):
                pts = f"{r['returned_points']} (refinement {r['returned_refinement']}; last mesh {r['points']})"
            print(f"| {r['tol']:g} | {r['met']} | {pts} | {r['cpu_s']:.2f} | {g(es)} / {g(em)} "
                  f"| {g(ts)}{extra} / {g(tm)} | {flag(rs_)}{g(rs_, '{:.2f}')}{flag(rs_)} / {flag(rm)}{rm_s}{flag(rm)} "
                  f"| {where} | {g(e.get('inputs'))} / {g(r.get('true_inputs'))} |")
        us = uniform(name)
        if us:
            print(f"\nFixed Radau meshes (cold `solve(oc.Radau(N, degree=p))`, CPU incl. build; multipliers relative to "
                  f"the reference's largest load):\n")
            print("| N x p | points | CPU s | true states | true multipliers |")
            print("|---|---|---|---|---|")
            for u in us:
                if "true_states" not in u:
                    print(f"| {u['N']} x {u['degree']} | | {u.get('killed') or u.get('exception')} | | |")
                    continue
                print(f"| {u['N']} x {u['degree']} | {u['points']} | {u['cpu_s']:.2f} | {g(u['true_states'])} | "
                      f"{g(u.get('true_multipliers'))} |")
            print("\nCheapest fixed mesh meeting each tolerance in truth (states and multipliers), against the refined solve:\n")
            print("| tol | fixed mesh | its CPU s | refined CPU s | refined / fixed |")
            print("|---|---|---|---|---|")
            for r in rs:
                if "true_states" not in r:
                    continue
                ok = [u for u in us if "true_states" in u and u["true_states"] <= r["tol"]
                      and (u.get("true_multipliers") or 0) <= r["tol"]]
                if not ok:
                    print(f"| {r['tol']:g} | none in the ladder | | {r['cpu_s']:.2f} | |")
                    continue
                b = min(ok, key=lambda u: u["cpu_s"])
                print(f"| {r['tol']:g} | {b['N']} x {b['degree']} ({b['points']} points) | {b['cpu_s']:.2f} | "
                      f"{r['cpu_s']:.2f} | {r['cpu_s'] / b['cpu_s']:.1f} |")
    print(f"\nCounts: {summary}")


if __name__ == "__main__":
    main()
