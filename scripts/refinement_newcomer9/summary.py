"""Counts and ranges over every runs_*.jsonl: runs, met, not met, killed, exceptions; true/estimate ranges on the
met runs; the met-in-truth share of the not-met runs; the largest CPU and mesh.

    python summary.py
"""
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
rows = []
for p in sorted(HERE.glob("runs_*.jsonl")):
    rows += [json.loads(l) for l in p.read_text().splitlines() if l.strip()]
killed = [r for r in rows if r.get("killed")]
exc = [r for r in rows if r.get("exception")]
ok = [r for r in rows if not r.get("killed") and not r.get("exception")]
met = [r for r in ok if r["met"]]
notmet = [r for r in ok if not r["met"]]
print(f"{len(rows)} runs: {len(met)} met, {len(notmet)} not met, {len(killed)} killed, {len(exc)} exceptions")
for q in ("states", "multipliers"):
    ratios = [r["true"]["dense"][q] / r["estimate"][q] for r in met]
    pts = [r["true"]["points"][q] / r["estimate"][q] for r in met]
    print(f"met, {q}: true/estimate {min(ratios):.2f} .. {max(ratios):.2f} (dense grid), {min(pts):.2f} .. "
          f"{max(pts):.2f} (collocation points); true > tol on {sum(r['true']['dense'][q] > r['tol'] for r in met)}")
bad = [(r["problem"], r["tol"]) for r in met
       if any(not (0.1 <= r["true"]["dense"][q] / r["estimate"][q] <= 1) for q in ("states", "multipliers"))]
print("met runs outside [0.1, 1]:", bad or "none")
for r in notmet:
    t = r["true"]["dense"]
    print(f"not met {r['problem']} {r['tol']:g}{' maxref ' + str(r['maxref']) if r.get('maxref') else ''}: "
          f"{r['points']} points, CPU {r['cpu']:.1f} s; true {t['states']:.1e} / {t['multipliers']:.1e} "
          f"(within tol in truth: {t['states'] <= r['tol'] and t['multipliers'] <= r['tol']}); ratio "
          f"{t['states'] / r['estimate']['states']:.2f} / {t['multipliers'] / r['estimate']['multipliers']:.2f}")
big = max(ok, key=lambda r: r["cpu"])
print(f"largest CPU: {big['problem']} {big['tol']:g}: {big['cpu']:.1f} s, {big['points']} points")
big = max(ok, key=lambda r: r["points"])
print(f"largest mesh: {big['problem']} {big['tol']:g}: {big['points']} points, {big['cpu']:.1f} s")

# the summary grid of the report: one row per problem (and start), one column per tolerance
print()
order = ["smooth", "pl", "spline", "smooth_max", "pl_max", "smooth_w5", "pl_w5", "spline_w5", "smooth_w7", "pl_w7",
         "spline_w7"]
tols = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
print("| problem | " + " | ".join(f"{t:g}" for t in tols) + " |")
print("|---" * (len(tols) + 1) + "|")
for name in order:
    for start in (None, "100,5"):
        cells, any_ = [], False
        for tol in tols:
            rs = [r for r in ok if r["problem"] == name and r["tol"] == tol and r.get("start") == start
                  and not r.get("maxref")]
            if not rs:
                cells.append("")
                continue
            any_ = True
            r = rs[-1]
            t, e = r["true"]["dense"], r["estimate"]
            word = "met" if r["met"] else "**not met**"
            cells.append(f"{word}, {r['points']} pts, {r['cpu']:.1f} s, {t['states'] / e['states']:.2f} / "
                         f"{t['multipliers'] / e['multipliers']:.2f}")
        if any_:
            label = name + (" (start Radau 100 x 5)" if start else "")
            print(f"| `{label}` | " + " | ".join(cells) + " |")
