"""runs_before.jsonl and runs_after.jsonl as one markdown table (results/bench/refinement_order_two_paths.md).

    python table.py"""
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE.parents[1] / "results" / "bench" / "refinement_order_two_paths.md"


def rows(name):
    path = HERE / f"runs_{name}.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def cell(r):
    if r is None:
        return "-"
    if "error" in r:
        return r["error"]
    ratio = lambda x: "n/a" if x != x else "exact" if x < 1e-3 else f"{x:.2f}"  # noqa: E731 (nan: not computed; <1e-3: rounding)
    met = "met" if r["met"] else "**not met**"
    return f"{met}, {r['points']} pts, {r['cpu']:.1f} s, {ratio(r['ratio_states'])} / {ratio(r['ratio_loads'])}"


before, after = rows("before"), rows("after")
key = lambda r: (r["problem"], r["coordinates"], r["tol"])  # noqa: E731
b = {key(r): r for r in before}
lines = ["# A path constraint of the coordinates alone (order two): before and after session 32", "",
         "Each cell: met or not, final points, CPU s, true error / estimate for the states and the loads (the hinge force over",
         "the record's load scale; n/a: not computed, for Bryson-Denham). References: the stop pendulum's three-phase",
         "reference of `tests/test_refinement_state_arcs.py` (junction times free, torque continuous), Bryson and Ho's closed",
         "form for Bryson-Denham. Before: the code at be055a8 (`bash grid_before.sh`, joint coordinates only); after: `bash",
         "grid.sh after`. One run each: `python run.py PROBLEM TOL [--coordinates maximal]` in `scripts/order_two_paths/`.",
         "At 1e-8 the phase reference is not converged itself (its junction times move 3e-7 s between 20 x Radau 5 and",
         "60 x Radau 9 per phase: `python reference_check.py`), so the 1e-8 ratios judge the reference as much as the solve.", "",
         "| problem | coordinates | tolerance | before | after |", "|---|---|---|---|---|"]
for r in after:
    lines.append(f"| {r['problem']} | {r['coordinates']} | {r['tol']:g} | {cell(b.get(key(r)))} | {cell(r)} |")
lines += ["", "pend_sin: `sin(rod.psi) >= sin 0.5`; pend_x: `rod.x >= (L/2) sin 0.5` (the rod's centre); bd_wall: `block.x <= 1/9` "
          "with `subject_to`, the block on a prismatic joint.", ""]
OUT.write_text("\n".join(lines))
print(OUT)
