"""Eighth newcomer check of ``solve(tolerance=...)`` on state bounds held over an arc (see README.md here).

    python nc8.py ref PROBLEM            # the reference's own accuracy (coarse vs fine) and junction times
    python nc8.py one PROBLEM TOL [MAX_REFINEMENTS]  # one solve, prints ROW {json}
    python nc8.py all PROBLEM [TOL ...]  # each tolerance in its own subprocess, CPU capped (--cap 120 s)

PROBLEMs: pend (rod on a revolute joint, joint coordinates, angle lower bound), pend_max (the same,
coordinates="maximal"), speed (block on a rail, speed bound), bd12 (Bryson-Denham, wall 1/12),
vert (Bryson-Denham moved vertically against gravity, wall 1/7), pend_b (a second pendulum: T 2.5 s,
1.2 -> 0.7 rad, stop at 0.4 rad).
"""
from __future__ import annotations

import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
G = 9.81

# ---------------------------------------------------------------- problems through the public API
PEND = dict(M=1.0, L=1.0, T=2.0, p0=1.0, p1=0.8, lo=0.5, t1g=0.7, t2g=1.4)
PEND_B = dict(M=1.0, L=1.0, T=2.5, p0=1.2, p1=0.7, lo=0.4, t1g=0.9, t2g=1.8)   # pend_b: a second pendulum


def _pend_variant(name):
    """pend_b takes PEND_B's numbers (PEND is rebound at import in the subprocess: one problem per process)."""
    if name == "pend_b":
        PEND.update(PEND_B)
SPEED = dict(D=1.0, T=1.0, vmax=1.2)
BD12 = dict(wall=1 / 12)
VERT = dict(wall=1 / 7)


def build(name: str):
    import ocp_constraints as oc
    _pend_variant(name)
    if name in ("pend", "pend_max", "pend_b"):
        M, L, T = PEND["M"], PEND["L"], PEND["T"]
        model = oc.Model("stop_pendulum", gravity=(0.0, -G, 0.0))
        rod = model.add_body("rod", M, M * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
        oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
        model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
        kw = {"coordinates": "maximal"} if name == "pend_max" else {}
        pr = oc.OptimalControlProblem(model, t_final=T, **kw)
        pr.initial({"rod.psi": PEND["p0"], "rod.omega_z": 0.0})
        pr.final({"rod.psi": PEND["p1"], "rod.omega_z": 0.0})
        pr.bound("rod.psi", lower=PEND["lo"])
        pr.minimize_effort(["motor"])
        return pr
    if name in ("speed", "bd12", "vert"):
        vertical = name == "vert"
        model = oc.Model(name, gravity=(0.0, -G, 0.0))
        block = model.add_body("block", 1.0, np.diag([0.01, 0.01, 0.01]), rotation="321")
        E = [ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])]
        along = 1 if vertical else 0          # the rail's axis
        for k in range(3):
            if k != along:
                model.add_constraint(f"rail.v{k + 1}", ca.dot(E[k], block.com.v), joint="rail",
                                     position=block.com.position[k])
        for k in range(3):
            model.add_constraint(f"rail.w{k + 1}", ca.dot(E[k], block.omega), joint="rail")
        u = model.add_input("u")
        model.add_force("push", block.com, ca.vertcat(0, u, 0) if vertical else ca.vertcat(u, 0, 0))
        if name == "speed":
            pr = oc.OptimalControlProblem(model, t_final=SPEED["T"])
            pr.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
            pr.final({"block.x": SPEED["D"], "block.vbar_x": 0.0})
            pr.bound("block.vbar_x", upper=SPEED["vmax"])
        else:
            wall = BD12["wall"] if name == "bd12" else VERT["wall"]
            c, v = ("block.y", "block.vbar_y") if vertical else ("block.x", "block.vbar_x")
            pr = oc.OptimalControlProblem(model, t_final=1.0)
            pr.initial({c: 0.0, v: 1.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
            pr.final({c: 0.0, v: -1.0})
            pr.bound(c, -1.0, wall)
        pr.minimize_effort(["u"])
        return pr
    raise SystemExit(f"unknown problem {name}")


# ---------------------------------------------------------------- references
def pend_spec():
    M, L, T, lo = PEND["M"], PEND["L"], PEND["T"], PEND["lo"]
    IA, k = M * L**2 / 3, M * G * L / 2
    hold = k * np.sin(lo)
    return dict(nx=2, nu=1, T=T, t1=PEND["t1g"], t2=PEND["t2g"],
                f=lambda x, u: ca.vertcat(x[1], (u[0] - k * ca.sin(x[0])) / IA),
                L=lambda x, u: u[0] ** 2, x0=[PEND["p0"], 0.0], xT=[PEND["p1"], 0.0],
                entry=lambda x: ca.vertcat(x[0] - lo, x[1]), middle=lambda x, d: (x, d * hold**2),
                path=None, u_arc=lambda x: [hold],        # the bound checked on the result (cmd_ref)
                guess_x=lambda t: [max(lo, PEND["p0"] - t), 0.0], guess_u=hold)


def speed_spec():
    D, T, vm = SPEED["D"], SPEED["T"], SPEED["vmax"]
    return dict(nx=2, nu=1, T=T, t1=0.3, t2=0.7, f=lambda x, u: ca.vertcat(x[1], u[0]), L=lambda x, u: u[0] ** 2,
                x0=[0.0, 0.0], xT=[D, 0.0], entry=lambda x: x[1] - vm,
                middle=lambda x, d: (ca.vertcat(x[0] + vm * d, x[1]), 0 * d),
                path=None, u_arc=lambda x: [0.0], guess_x=lambda t: [D * t / T, vm * 0.9])


def bd_spec(wall, g=0.0):
    return dict(nx=2, nu=1, T=1.0, t1=3 * wall, t2=1 - 3 * wall, f=lambda x, u: ca.vertcat(x[1], u[0] - g), L=lambda x, u: u[0] ** 2,
                x0=[0.0, 1.0], xT=[0.0, -1.0], entry=lambda x: ca.vertcat(x[0] - wall, x[1]),
                middle=lambda x, d: (x, d * g**2), path=lambda x: wall - x[0], u_arc=lambda x: [g],
                guess_x=lambda t: [float(v[0]) for v in bd_closed(np.array([t]), wall)[:2]], guess_u=g)


def spec(name):
    _pend_variant(name)
    return {"pend": pend_spec, "pend_max": pend_spec, "pend_b": pend_spec, "speed": speed_spec,
            "bd12": lambda: bd_spec(BD12["wall"]), "vert": lambda: bd_spec(VERT["wall"], G)}[name]()


def bd_closed(t, wall):
    s = np.minimum(t, 1 - t)
    off = s < 3 * wall
    r = np.where(off, 1 - s / (3 * wall), 0.0)
    return np.where(off, wall * (1 - r**3), wall), r**2 * np.where(t <= 0.5, 1.0, -1.0), -2 / (3 * wall) * r


def speed_closed(t):
    D, T, vm = SPEED["D"], SPEED["T"], SPEED["vmax"]
    t1 = 1.5 * (T - D / vm)
    c = 2 * vm / t1**2
    s = np.minimum(t, T - t)
    v = np.where(s < t1, c * (t1 * s - s**2 / 2), vm)
    xs = np.where(s < t1, c * (t1 * s**2 / 2 - s**3 / 6), 2 * vm * t1 / 3 + vm * (s - t1))
    x = np.where(t <= T / 2, xs, D - xs)
    u = np.where(s < t1, c * (t1 - s), 0.0) * np.where(t <= T / 2, 1.0, -1.0)
    return x, v, u, (t1, T - t1)


def reference(name, N=20, s=5):
    """The phase reference with the input continuous at the junctions (session 26): with free junctions alone J is flat
    in them and N = 80 put the entry 5e-7 s early (``python ref_continuity.py``: continuous, N = 40 and 80 agree to
    1e-9 s)."""
    from reference import Phases
    return Phases(spec(name), N, s).solve(continuity=True)


def ref_quantities(name, t, ph=None):
    """Library-named states and multipliers of the reference at times t. Closed forms where there is one (speed,
    bd12, vert), else the phase reference ``ph``; multipliers by Newton-Euler."""
    st, lam = {}, {}
    if name.startswith("pend"):
        x, u = ph.evaluate(t)
        psi, w = x
        M, L = PEND["M"], PEND["L"]
        IA, k = M * L**2 / 3, M * G * L / 2
        acc = (u[0] - k * np.sin(psi)) / IA
        r = L / 2
        st = {"rod.x": r * np.sin(psi), "rod.y": -r * np.cos(psi), "rod.z": 0 * t, "rod.psi": psi, "rod.theta": 0 * t,
              "rod.phi": 0 * t, "rod.vbar_x": r * np.cos(psi) * w, "rod.vbar_y": r * np.sin(psi) * w,
              "rod.vbar_z": 0 * t, "rod.omega_x": 0 * t, "rod.omega_y": 0 * t, "rod.omega_z": w}
        ax = r * (np.cos(psi) * acc - np.sin(psi) * w**2)
        ay = r * (np.sin(psi) * acc + np.cos(psi) * w**2)
        lam = {"hinge.v1.lambda": M * ax, "hinge.v2.lambda": M * ay + M * G, "hinge.v3.lambda": 0 * t,
               "hinge.w1.lambda": 0 * t, "hinge.w2.lambda": 0 * t}
        return st, lam, u[0]
    if name == "speed":
        x, v, u, _ = speed_closed(t)
        c, vv, along = x, v, 0
    else:
        wall = BD12["wall"] if name == "bd12" else VERT["wall"]
        c, vv, u = bd_closed(t, wall)
        along = 1 if name == "vert" else 0
        if name == "vert":
            u = u + G
    z = 0 * t
    pos, vel = [z, z, z], [z, z, z]
    pos[along], vel[along] = c, vv
    st = {"block.x": pos[0], "block.y": pos[1], "block.z": pos[2], "block.psi": z, "block.theta": z, "block.phi": z,
          "block.vbar_x": vel[0], "block.vbar_y": vel[1], "block.vbar_z": vel[2], "block.omega_x": z,
          "block.omega_y": z, "block.omega_z": z}
    lam = {f"rail.w{k}.lambda": z for k in (1, 2, 3)}
    for k in range(3):
        if k != along:
            lam[f"rail.v{k + 1}.lambda"] = z + (G if k == 1 else 0.0)
    return st, lam, u


def junctions(name, ph=None):
    if name == "speed":
        return speed_closed(np.zeros(1))[3]
    if name in ("bd12", "vert"):
        w = BD12["wall"] if name == "bd12" else VERT["wall"]
        return (3 * w, 1 - 3 * w)
    return (ph.t1, ph.t2)


def horizon(name):
    _pend_variant(name)
    return {"pend": PEND["T"], "pend_max": PEND["T"], "pend_b": PEND["T"], "speed": SPEED["T"]}.get(name, 1.0)


# ---------------------------------------------------------------- commands
def cmd_ref(name):
    T = horizon(name)
    t0 = time.process_time()
    a = reference(name, 40)
    b = reference(name, 80)
    cpu = time.process_time() - t0
    jt = sorted(set([b.t1, b.t2]))
    t = np.unique(np.concatenate([np.linspace(0, T, 4001), [x + d for x in jt for d in (-1e-9, 1e-9)]]))
    sa, la, ua = ref_quantities(name, t, a) if name.startswith("pend") else (None, None, None)
    xa, uA = a.evaluate(t)
    xb, uB = b.evaluate(t)
    lo_b = spec(name)
    viol = {"pend": lambda: float((PEND["lo"] - xb[0]).max()), "pend_b": lambda: float((PEND["lo"] - xb[0]).max()), "speed": lambda: float((xb[1] - SPEED["vmax"]).max())}
    out = {"bound_violation_fine": viol[name]() if name in viol else None, "problem": name, "J_coarse": a.J, "J_fine": b.J, "t1": [a.t1, b.t1], "t2": [a.t2, b.t2],
           "states_coarse_vs_fine": float(np.abs(xa - xb).max()), "input_coarse_vs_fine": float(np.abs(uA - uB).max()),
           "cpu_s": cpu}
    if name.startswith("pend"):
        _, lb, _ = ref_quantities(name, t, b)
        out["loads_coarse_vs_fine"] = max(float(np.abs(la[k] - lb[k]).max()) for k in la)
    else:   # the closed form against the fine phase reference
        st, _, u = ref_quantities(name, t)
        cv = ("block.y", "block.vbar_y") if name == "vert" else ("block.x", "block.vbar_x")
        out["closed_vs_fine_states"] = float(max(np.abs(st[cv[0]] - xb[0]).max(), np.abs(st[cv[1]] - xb[1]).max()))
        out["closed_vs_fine_input"] = float(np.abs(u - uB[0]).max())
        out["closed_junctions"] = list(junctions(name))
    print("REF " + json.dumps(out))


def cmd_one(name, tol, max_refinements=None):
    pr = build(name)
    t0 = time.process_time()
    try:
        kw = {} if max_refinements is None else {"max_refinements": max_refinements}
        sol = pr.solve(tolerance=tol, progress=False, **kw)
    except Exception as e:  # noqa: BLE001 - recorded as a finding
        import traceback
        print("ROW " + json.dumps({"problem": name, "tol": tol, "exception": f"{type(e).__name__}: {e}"[:600],
                                   "cpu_s": time.process_time() - t0}))
        traceback.print_exc()
        return
    cpu = time.process_time() - t0
    r = sol.mesh_refinement
    T = horizon(name)
    mesh = np.asarray(r["mesh"], float) * T
    ph = reference(name, 80) if name.startswith("pend") else None
    jt = junctions(name, ph)
    t = np.concatenate([np.linspace(mesh[k], mesh[k + 1], 17)[:-1] for k in range(len(mesh) - 1)] + [[T]]
                       + [[x - 1e-9, x + 1e-9] for x in jt])
    t = np.unique(np.clip(t, 0, T))
    st, lam, uref = ref_quantities(name, t, ph)
    names = set(sol.sample_names())
    errs = {k: float(np.abs(sol.interpolate(k, t) - v).max()) for k, v in st.items() if k in names}
    worst = max(errs, key=errs.get)
    load_scale = r.get("load_scale")
    lerr = {k: float(np.abs(sol.interpolate(k, t) - v).max()) for k, v in lam.items() if k in names}
    ref_largest = max(float(np.abs(v).max()) for v in lam.values())
    scale = load_scale if load_scale else ref_largest
    lworst = max(lerr, key=lerr.get) if lerr else None
    est = r.get("estimate") or {}
    uname = "motor" if name.startswith("pend") else "u"
    uerr = float(np.abs(sol.interpolate(uname, t) - uref).max() / np.abs(uref).max())
    # the gap from the bound on the reference's arc (the message's claim where it names an arc floor)
    bname, (lo, hi) = next(iter(pr.bounds.items()))
    on = (t > jt[0] + 1e-3) & (t < jt[1] - 1e-3)
    vb = sol.interpolate(bname, t[on])
    bound = lo if abs(np.median(vb) - lo) < abs(np.median(vb) - hi) else hi    # the bound held on the arc
    row = {"problem": name, "tol": tol, "met": r["met"], "message": r["message"][:300], "points": r["history"][-1]["points"],
           "intervals": r["history"][-1]["intervals"], "refinements": len(r["history"]), "cpu_s": cpu,
           "est_states": est.get("states"), "est_multipliers": est.get("multipliers"), "est_inputs": est.get("inputs"),
           "true_states": errs[worst], "worst_state": worst, "true_multipliers": lerr[lworst] / scale if lerr else None,
           "worst_multiplier": lworst, "load_scale": load_scale, "ref_largest_load": ref_largest,
           "true_inputs": uerr, "junctions_ref": list(jt),
           "switches_located": r.get("switches_located"),
           "arc_gap_max": float(np.abs(vb - bound).max()) if on.any() else None,
           "bounds_passed": r.get("bounds_passed_between_points"), "objective": sol.objective,
           "returned_refinement": r.get("returned_refinement"), "estimate_keys": sorted(est.keys())}
    print("ROW " + json.dumps(row, default=str))


def cmd_all(name, tols, cap):
    out = HERE / f"runs_{name}.jsonl"
    for tol in tols:
        def limit():
            resource.setrlimit(resource.RLIMIT_CPU, (cap, cap))
        w0 = time.time()
        p = subprocess.run([sys.executable, str(HERE / "nc8.py"), "one", name, repr(tol)], capture_output=True,
                           text=True, preexec_fn=limit, cwd=HERE)
        rows = [ln[4:] for ln in p.stdout.splitlines() if ln.startswith("ROW ")]
        if rows:
            row = json.loads(rows[0])
        else:
            row = {"problem": name, "tol": tol, "killed": p.returncode, "stderr_tail": p.stderr[-800:]}
        row["wall_s"] = time.time() - w0
        row["cap_s"] = cap
        if p.stderr.strip():
            row["stderr_tail"] = p.stderr[-1500:]
        with out.open("a") as f:
            f.write(json.dumps(row) + "\n")
        print(json.dumps({k: row.get(k) for k in ("problem", "tol", "met", "points", "cpu_s", "est_states",
                                                  "true_states", "est_multipliers", "true_multipliers", "killed",
                                                  "exception")}), flush=True)


if __name__ == "__main__":
    a = sys.argv[1:]
    if a[0] == "ref":
        cmd_ref(a[1])
    elif a[0] == "one":
        cmd_one(a[1], float(a[2]), int(a[3]) if len(a) > 3 else None)
    elif a[0] == "all":
        cap = 120
        if "--cap" in a:
            i = a.index("--cap")
            cap = int(a[i + 1])
            del a[i:i + 2]
        cmd_all(a[1], [float(x) for x in a[2:]] or [1e-3, 1e-4, 1e-5, 1e-6, 1e-7], cap)
