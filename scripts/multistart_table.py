"""The local optima found by a batch of multi-start solves (``examples/batch_multistart.toml``).

    python scripts/multistart_table.py results/batch/multistart

reads ``DIR/batch.csv`` and each run's ``summary.json`` (``"multistart"``), prints one line per
run (seed, starts solved, best objective, the distinct optima with how many starts reached each)
and the optima of all runs together, clustered to the runs' relative tolerance, and writes the
same as ``DIR/multistart.md``.
"""
from __future__ import annotations

import csv
import json
import sys
from pathlib import Path


def main(folder: str) -> int:
    from ocp_constraints.ocp.multistart import cluster_objectives

    folder = Path(folder)
    lines = ["| run | seed | starts solved | best objective | local optima (starts reaching each) |", "|---|---:|---:|---:|---|"]
    pooled, rtol = {}, None
    with open(folder / "batch.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            path = folder / "runs" / row["id"] / "summary.json"
            if not path.is_file():
                lines.append(f"| {row['id']} | | | {row['status']} | |")
                continue
            ms = json.loads(path.read_text()).get("multistart")
            if not ms:
                continue
            rtol = ms["rtol"]
            optima = ", ".join(f"{o['objective']:.6f} ({o['count']})" for o in ms["optima"])
            best = min((o["objective"] for o in ms["optima"]), default=float("nan"))
            lines.append(f"| {row['id']} | {ms['seed']} | {ms['succeeded']} of {ms['starts']} | {best:.6f} | {optima} |")
            for k, run in enumerate(ms["runs"]):
                if run["status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level") and run["objective"] is not None:
                    pooled[(ms["seed"], k)] = run["objective"]
    # start 0 is the task's own guess in every run: count it once
    pooled = {key: f for key, f in pooled.items() if key[1] > 0 or key[0] == min(s for s, _ in pooled)}
    clusters = cluster_objectives(dict(enumerate(pooled.values())), rtol or 1e-5)
    lines.append("")
    lines.append(f"All runs together ({len(pooled)} distinct starts): " +
                 ", ".join(f"{c['objective']:.6f} ({c['count']})" for c in clusters))
    text = "\n".join(lines)
    (folder / "multistart.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    raise SystemExit(main(sys.argv[1]))
