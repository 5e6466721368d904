"""The library's refined solutions (library_run.py's .npz) against the phase reference (reference.py's .npz).

    python scripts/crane_reference/compare.py --ref REF.npz --others A.npz B.npz --libs lib_0.0001.npz ...

1. The reference's own spread: REF against each of --others on 200001 uniform normalized times (states, F, T,
   rope force / the library's load_scale), everywhere and outside +-1e-6, +-1e-5 of T around REF's junctions.
2. Per library solve: states max |difference| on its dense normalized grid (sol.interpolate against the
   reference's collocation polynomials at the same tau = t/T), |T - T_ref|, the rope force on the load at the
   library's points (sol.loads()) and midway between them (its multipliers interpolated), divided by
   rec["load_scale"]; ratios true/estimate; the same outside the junction windows.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from reference import PhaseSolution  # noqa: E402

WINDOWS = (0.0, 1e-6, 1e-5)


def outside(u, junctions, w):
    if w == 0:
        return np.ones(len(u), bool)
    return np.min(np.abs(u[:, None] - np.asarray(junctions)[None, :]), axis=1) > w


def ref_spread(ref, other, scale):
    u = np.linspace(0.0, 1.0, 200001)
    dX = np.abs(ref.state_n(u) - other.state_n(u)).max(axis=0)
    dF = np.abs(ref.push_n(u) - other.push_n(u))
    dR = np.abs(ref.rope_n(u) - other.rope_n(u)).max(axis=0) / scale
    jn = np.r_[ref.bounds[1:-1] / ref.T, other.bounds[1:-1] / other.T]
    out = {"T": abs(ref.T - other.T), "J": abs(ref.meta["objective"] - other.meta["objective"]),
           "junctions": float(np.abs(ref.bounds / ref.T - other.bounds / other.T).max())}
    for w in WINDOWS:
        m = outside(u, jn, w)
        out[w] = dict(states=dX[m].max(), states_at=u[m][np.argmax(dX[m])], F=dF[m].max(), rope=dR[m].max(),
                      rope_at=u[m][np.argmax(dR[m])])
    return out


def library_errors(ref, path):
    z = np.load(path)
    info = json.loads(str(z["info"]))
    T = info["t_final"]
    scale = info["load_scale"]
    jn = ref.bounds[1:-1] / ref.T
    tau = z["tau"]
    dX = np.abs(z["Xd"] - ref.state_n(tau)).max(axis=0)
    up = z["t"] / T
    Rp = ref.rope_n(up)
    dRp = np.abs(z["Fp"][:2] - Rp).max(axis=0) / scale
    zp = np.abs(z["Fp"][2]).max() / scale
    um = z["mid"] / T
    dRm = np.abs(z["Fmid"][:2] - ref.rope_n(um)).max(axis=0) / scale if z["Fmid"].size else np.zeros(0)
    est = info["estimate"]
    out = dict(tol=info["tolerance"], met=info["met"], points=info["points"], cpu=info["cpu"],
               total_cpu=info.get("total_cpu_s"), T=T, dT=abs(T - ref.T), est_states=est.get("states"),
               est_loads=est.get("multipliers"), scale=scale, objective=info["objective"], Fz=zp)
    for w in WINDOWS:
        m = outside(tau, jn, w)
        mp = outside(up, jn, w)
        mp0 = mp & (up > 0)                     # Radau: no collocation point at t = 0
        mm = outside(um, jn, w)
        d = dict(states=dX[m].max(), states_at=tau[m][np.argmax(dX[m])],
                 loads_pts=dRp[mp0].max(), loads_pts_at=up[mp0][np.argmax(dRp[mp0])],
                 loads_t0=dRp[0], loads_mid=dRm[mm].max() if dRm.size else np.nan,
                 loads_mid_at=um[mm][np.argmax(dRm[mm])] if dRm.size else np.nan)
        d["loads"] = max(d["loads_pts"], d["loads_mid"]) if dRm.size else d["loads_pts"]
        out[w] = d
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ref", type=Path, required=True)
    ap.add_argument("--others", type=Path, nargs="*", default=[])
    ap.add_argument("--libs", type=Path, nargs="*", default=[])
    ap.add_argument("--scale", type=float, default=613.12500002573, help="load scale for the reference's spread")
    args = ap.parse_args()
    ref = PhaseSolution.load(args.ref)
    m = ref.meta
    print(f"reference {args.ref.name}: K={ref.K} N={ref.N}, {m['status']}, T = {ref.T:.12f}, J = {m['objective']:.13f}; "
          f"junctions/T = " + ", ".join(f"{b / ref.T:.9f}" for b in ref.bounds[1:-1]))
    print(f"  eq residual {m['eq_residual']:.1e}, largest inequality {m['ineq_max']:.1e}, free-phase inner max "
          f"{m.get('free_inner_max')}, arc duals {m.get('arc_dual_min')}..{m.get('arc_dual_max')}")
    for o in args.others:
        other = PhaseSolution.load(o)
        s = ref_spread(ref, other, args.scale)
        print(f"spread against {o.name} (K={other.K} N={other.N}, {other.meta['status']}): |dT| {s['T']:.1e} s, "
              f"|dJ| {s['J']:.1e}, junctions {s['junctions']:.1e} of T")
        for w in WINDOWS:
            d = s[w]
            print(f"   outside +-{w:g}: states {d['states']:.1e} (at {d['states_at']:.6f}), F {d['F']:.1e} N, rope/scale "
                  f"{d['rope']:.1e} (at {d['rope_at']:.6f})")
    rows = []
    for p in args.libs:
        e = library_errors(ref, p)
        rows.append(e)
        print(f"library tol {e['tol']:g}: met {e['met']}, {e['points']} points, CPU {e['cpu']:.1f} s, T {e['T']:.12f} "
              f"(|dT| {e['dT']:.1e}), J {e['objective']:.13f} (ref {m['objective']:.13f}), estimate states "
              f"{e['est_states']:.1e} loads {e['est_loads']:.1e}, load_scale {e['scale']:.2f}, |F_z|/scale {e['Fz']:.1e}")
        for w in WINDOWS:
            d = e[w]
            print(f"   outside +-{w:g}: states {d['states']:.2e} (at {d['states_at']:.6f}) ratio {d['states'] / e['est_states']:.2f}; "
                  f"loads at points {d['loads_pts']:.2e} (at {d['loads_pts_at']:.6f}), midway {d['loads_mid']:.2e} (at "
                  f"{d['loads_mid_at']:.6f}), ratio {d['loads'] / e['est_loads']:.2f}; at t=0 {d['loads_t0']:.1e}")
    if rows:
        print("\n| TOL | met | points | CPU s | T error (s) | states true | states est | ratio | loads true | loads est | ratio |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for e in rows:
            d = e[0.0]
            print(f"| {e['tol']:g} | {e['met']} | {e['points']} | {e['cpu']:.1f} | {e['dT']:.1e} | {d['states']:.1e} | "
                  f"{e['est_states']:.1e} | {d['states'] / e['est_states']:.2f} | {d['loads']:.1e} | {e['est_loads']:.1e} | "
                  f"{d['loads'] / e['est_loads']:.2f} |")
        for w in WINDOWS[1:]:
            print(f"\noutside +-{w:g} of T around the reference's junctions:\n")
            print("| TOL | states true | ratio | loads true | ratio |")
            print("|---|---|---|---|---|")
            for e in rows:
                d = e[w]
                print(f"| {e['tol']:g} | {d['states']:.1e} | {d['states'] / e['est_states']:.2f} | {d['loads']:.1e} | "
                      f"{d['loads'] / e['est_loads']:.2f} |")


if __name__ == "__main__":
    main()
