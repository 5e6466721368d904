"""Tables of results.jsonl (python report.py [FILE]), markdown to stdout."""
import json, os, sys

# The folder of the check (a later check runs this report on its own: scripts/refinement_newcomer7/report.py sets
# NEWCOMER_DIR, and its models.py gives REPORT_NAMES).
HERE = os.environ.get("NEWCOMER_DIR") or os.path.dirname(os.path.abspath(__file__))
fn = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "results.jsonl")
recs = [json.loads(l) for l in open(fn)]
f = lambda v, fmt=".1e": "-" if v is None else format(v, fmt)
NAMES = {"fourbar": "1. four-bar linkage, effort + ground pin O's load (closed chain)",
         "sph": "2. rod on a ball-and-socket joint, quaternion, three torques (spatial)",
         "sleigh": "3. Chaplygin sleigh, knife edge by hand (nonholonomic)",
         "track": "4. pendulum tracking -pi/2 + A sin(w t), |tau| <= 2.5 active on three arcs (explicit time)",
         "fourbar_max": "1b. the four-bar in maximal coordinates (coordinates=\"maximal\")",
         "fourbar_turn": "1c. the four-bar, a full crank turn in 1.2 s, load weight 0.05",
         "fourbar_toggle": "1d. the four-bar near a toggle (a, b, c, d = 0.33, 0.5, 0.45, 0.6; transmission angle up to 156 deg), full turn",
         "sph_big": "2b. the ball-and-socket rod, a larger tilt (3-2-1 angles 1.2, 0.9, -1.0) in 1.5 s",
         "sph_negq": "2c. the ball-and-socket rod, its final pose given as -q (another motion: an extra turn in yaw)",
         "sleigh_turn": "3b. the sleigh parked a quarter turn sideways, (1, 1.5, pi/2) in 3 s",
         "track_fast": "4d. tracking a 6 Hz reference 0.3 sin(12 pi t), the torque bound never reached",
         "track_steep": "4b. tracking with a small effort weight (0.01) and |tau| <= 5: four arcs, steep torque between them",
         "track_steep@r3n40": "4c. the same refined from the mesh Radau 3 x 40 (solve(oc.Radau(40, degree=3), tolerance=tol))"}
if os.environ.get("NEWCOMER_DIR"):
    sys.path.insert(0, HERE)
    import models
    NAMES = models.REPORT_NAMES
for p in NAMES:
    rs = [r for r in recs if r["problem"] == p]
    if not rs:
        continue
    acc = next((r["ref_accuracy"] for r in rs if "ref_accuracy" in r), {})
    print(f"\n### {NAMES[p]}\n")
    print(f"Reference: Radau {acc.get('degree')} on {acc.get('N')} intervals, coarse vs fine on a dense grid: states "
          f"{f(acc.get('states_coarse_vs_fine'))}, loads {f(acc.get('loads_coarse_vs_fine_rel_peak'))} of the peak "
          f"{f(acc.get('peak_load'), '.4g')} N; objective {acc.get('objective_fine')!r} (coarse {acc.get('objective_coarse')!r})"
          + (f"; junctions (fractions of T) {[round(v, 8) for v in acc.get('junctions_fine')]}" if acc.get('junctions_fine') else "") + "\n")
    print("| tol | met | points | intervals | meshes (points per solve) | CPU s | estimate states / mult | true states / mult (dense) | true/estimate states / mult | true at points states / mult | objective - ref | where the true max is (t s, quantity) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        if "crash" in r:
            print(f"| {r['tol']} | **crash** | | | | {f(r.get('cpu'), '.1f')} | | | | | | {r['crash'][:300]} |")
            continue
        e, t, q, tp = r["estimate"], r["true"], r["ratio"], r["true_at_points"]
        w = t.get("where", {})
        ws = "; ".join(f"{k[:5]}: {w[k][1]} @ {w[k][0]:.4f}" for k in ("states", "multipliers") if k in w)

        def mark(x):
            if x is None:
                return "-"
            s = f"{x:.2f}"
            return f"**{s}**" if (r["met"] and (x > 1 or x < 0.1)) else s
        print(f"| {r['tol']} | {'yes' if r['met'] else '**NO**'} | {r['points']} | {r['intervals']} | {r.get('meshes')} | {r['cpu']:.1f} "
              f"| {f(e.get('states'))} / {f(e.get('multipliers'))} | {f(t['states'])} / {f(t['multipliers'])} "
              f"| {mark(q['states'])} / {mark(q['multipliers'])} | {f(tp['states'])} / {f(tp['multipliers'])} "
              f"| {r['objective'] - r['objective_ref']:+.1e} | {ws} |")
    print()
    for r in rs:
        extra = ""
        if r.get("estimate", {}).get("inputs") is not None:
            extra += f" Inputs' estimate {f(r['estimate']['inputs'])}."
        if r.get("switches_located"):
            extra += " switches_located (kind @ t s): " + ", ".join(f"{sw.get('kind')} {sw.get('quantity')} @ {sw.get('t'):.6f}" for sw in r["switches_located"]) + "."
        if r.get("bounds_passed_between_points"):
            extra += f" bounds_passed_between_points: {r['bounds_passed_between_points']}."
        if r.get("min_interval") is not None:
            extra += f" Shortest interval {r['min_interval']:.2e} s."
        print(f"- {r['tol']}: \"{r.get('message', r.get('crash'))}\"{extra}")
