"""Condensed summary of runs_*.jsonl (one line per variant): python summary.py > summary.md"""
import json
from pathlib import Path

ORDER = ["block_tf_eps0.01", "block_tf_eps0.01_maximal", "block_tf_eps0.0001", "block_tf_eps1e-06",
         "block_tf_speed_eps0.01", "block_tf_speed_eps0.01_maximal", "block_tf_speed_eps0.0001",
         "block_tf_speed_eps1e-06", "block_tf_speed_t0", "block_tf_speed_t0_maximal", "block_tf_speed_t0_meshat",
         "block_tf_speed_tend", "pendulum_tf", "pendulum_tf_maximal", "pendulum_tf_eps0.0001", "pendulum_tf_eps1e-06",
         "pendulum_tf_speed", "pendulum_tf_speed_maximal", "pendulum_tf_speed_eps0.0001",
         "pendulum_tf_speed_eps1e-06", "pendulum_tf_speed_path"]
HERE = Path(__file__).resolve().parent
rows = {p.stem[5:]: [json.loads(l) for l in p.read_text().splitlines()] for p in HERE.glob("runs_*.jsonl")}


def rng(v):
    v = [x for x in v if x is not None]
    return f"{min(v):.2f}-{max(v):.2f}" if v else "floor"


print("| variant | 1e-4 | 1e-5 | 1e-6 | 1e-7 | max \\|T - T_ref\\| (s) | states true/est | multipliers true/est |")
print("|---|---|---|---|---|---|---|---|")
for k in ORDER:
    rs = {r["tol"]: r for r in rows[k]}
    cells = [(f"{'met' if rs[t]['met'] else '**no**'} {rs[t]['points']} / {rs[t]['cpu_s']:.1f}" if t in rs else "-")
             for t in (1e-4, 1e-5, 1e-6, 1e-7)]
    dT = max(abs(r["T_sol"] - r["T_ref"]) for r in rows[k])
    st = [r["ratio_states"] if (r["est_states"] or 0) > 1e-10 else None for r in rows[k]]
    mu = [r["ratio_multipliers"] if (r["est_mult"] or 0) > 1e-10 else None for r in rows[k]]
    print(f"| {k} | " + " | ".join(cells) + f" | {dT:.1e} | {rng(st)} | {rng(mu)} |")
