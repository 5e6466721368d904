"""Full messages and refinement histories of the not-met runs (the tables keep 300 characters).

    python messages.py [NAME ...]
"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
names = sys.argv[1:] or sorted(p.stem[5:] for p in HERE.glob("runs_*.jsonl"))
for name in names:
    for line in (HERE / f"runs_{name}.jsonl").read_text().splitlines():
        r = json.loads(line)
        if r.get("killed") or r.get("exception") or r.get("met"):
            continue
        extra = (f" max_refinements={r['maxref']}" if r.get("maxref") else "") + (
            f" start={r['start']}" if r.get("start") else "")
        print(f"## {name} {r['tol']:g}{extra}: returned_refinement {r.get('returned_refinement')}, "
              f"nonsmooth_intervals {r.get('nonsmooth')}, switches {r.get('switches')}")
        print(r["message"])
        for h in r["history"]:
            e = h.get("estimate") or {}
            print(f"   refinement {h['refinement']}: {h['intervals']} intervals, {h['points']} points, estimate states "
                  f"{e.get('states', float('nan')):.1e} multipliers {e.get('multipliers', float('nan')):.1e}, "
                  f"cpu {h.get('cpu_s') or 0:.2f} + companion {h.get('companion_cpu_s') or 0:.2f} s")
        print()
