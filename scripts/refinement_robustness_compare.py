"""Rows of several ``scripts/refinement_robustness.py --json`` files side by side (issue 19): per problem and
tolerance, each run's outcome, final points, solves and CPU; and, over the rows every run met, the CPU summed.

    python scripts/refinement_robustness_compare.py LABEL=FILE.json [LABEL=FILE.json ...] [--out FILE.md]

Used to choose the refinement's first mesh (``mesh_refinement.START``): each file a run of the robustness script
on a copy of the library with another START (``results/bench/refinement_start/``, whose README says how each was made).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


def _cell(row: dict | None) -> str:
    if row is None:
        return "(not run)"
    if row["outcome"] in ("met", "not met"):
        return f"{row['outcome']}, {row['points']} points, {row['solves']} solves, {row['cpu_s']:.1f} s"
    return row["outcome"]


def table(runs: dict[str, list[dict]]) -> str:
    """The markdown table of ``runs`` (label -> rows), rows in the first run's order."""
    keyed = {label: {(r["problem"], r["tolerance"]): r for r in rows} for label, rows in runs.items()}
    order = list(next(iter(keyed.values())))
    labels = list(runs)
    lines = ["| problem | tolerance | " + " | ".join(labels) + " |", "|---|---|" + "---|" * len(labels)]
    for key in order:
        lines.append(f"| {key[0]} | {key[1]:g} | " + " | ".join(_cell(keyed[lab].get(key)) for lab in labels) + " |")
    both = [k for k in order if all(keyed[lab].get(k, {}).get("outcome") == "met" for lab in labels)]
    sums = " | ".join(f"{sum(keyed[lab][k]['cpu_s'] for k in both):.1f} s" for lab in labels)
    counts = " | ".join(", ".join(f"{sum(1 for r in keyed[lab].values() if r['outcome'] == o)} {o}"
                                  for o in ("met", "not met", "cap")) for lab in labels)
    lines += [f"| CPU over the {len(both)} rows all met | | {sums} |", f"| outcomes | | {counts} |"]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="LABEL=FILE.json")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    runs = {}
    for spec in args.runs:
        label, _, path = spec.partition("=")
        runs[label] = json.loads(Path(path).read_text())
    text = table(runs)
    if args.out:
        args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
