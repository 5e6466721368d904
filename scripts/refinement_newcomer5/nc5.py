"""Newcomer check 5: solve(tolerance=TOL) of four problems (models.py) against the references of ref.py.

    python nc5.py run PROBLEM TOL        # one refined solve; its record as JSON on the last line
    python nc5.py all [PROBLEM ...]      # every tolerance, one subprocess at a time (CPU cap 120 s, wall 200 s),
                                         # appended to results.jsonl
PROBLEM in dpend, pend, rp, ft; dpend_r3n40: the double pendulum refined from the mesh Radau 3 x 40
(solve(oc.Radau(40, degree=3), tolerance=TOL)) instead of the default start.
"""
import json, os, resource, subprocess, sys, time
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
TOLS = ["1e-3", "1e-4", "1e-5", "1e-6"]
CPU_CAP, WALL_CAP = 120, 200

STATES = {"dpend": ["upper.psi", "lower.psi", "upper.omega_z", "lower.omega_z", "elbow.angle", "elbow.rate"],
          "pend": ["rod.psi", "rod.omega_z"], "ft": ["rod.psi", "rod.omega_z"],
          "rp": ["slider.x", "arm.psi", "slider.vbar_x", "arm.omega_z"]}


def lib_state(sol, problem, name):
    if name == "elbow.angle":
        return np.asarray(sol.sample("lower.psi")) - np.asarray(sol.sample("upper.psi"))
    if name == "elbow.rate":
        return np.asarray(sol.sample("lower.omega_z")) - np.asarray(sol.sample("upper.omega_z"))
    return np.asarray(sol.sample(name), float)


ZERO_STATES = ["z", "theta", "phi", "vbar_z", "omega_x", "omega_y"]


def with_body_states(problem, ref):
    """Adds to a reference its bodies' x, y, psi, vbar_x, vbar_y, omega_z at its nodes (from its q, qd)."""
    import casadi as ca
    from ref import system
    S = system(problem)
    x = ca.vertcat(S["s"].q, S["s"].qd)
    fn = ca.Function("b", [x], [ca.vertcat(*S["body"].values())])
    vals = np.asarray(fn(ref["X"])).reshape(len(S["body"]), -1)
    for k, v in zip(S["body"], vals):
        ref["states"].setdefault(k, v)
    ref["body_names"] = list(S["body"])
    ref["bodies"] = sorted({k.split(".")[0] for k in S["body"]})
    return ref


def errors(sol, problem, ref):
    """states: every body coordinate and speed (what the library's estimate covers), plus the joint angles and rates;
    states_joint: the joint angles and rates only."""
    from ref import evaluate
    t = np.asarray(sol.t, float); T = float(sol.t_final)
    frac = t / T
    out = {"states": 0.0, "states_joint": 0.0, "multipliers": 0.0, "where": {}}
    names = list(dict.fromkeys(STATES[problem] + ref["body_names"]))
    for n in names + [f"{b}.{c}" for b in ref["bodies"] for c in ZERO_STATES]:
        rv = evaluate(ref, n, frac, "state") if n in ref["states"] else 0.0
        d = lib_state(sol, problem, n) - rv
        if n in ref["angles"] or n.endswith(".psi"):
            d = (d + np.pi) % (2 * np.pi) - np.pi
        k = int(np.argmax(np.abs(d)))
        if abs(d[k]) > out["states"]:
            out["states"] = float(abs(d[k])); out["where"]["states"] = (float(t[k]), n)
        if n in STATES[problem]:
            out["states_joint"] = max(out["states_joint"], float(abs(d[k])))
    scale = float(sol.mesh_refinement["history"][-1]["load_scale"])
    for n in list(ref["loads"]) + list(ref["zeros"]):
        lv = np.asarray(sol.sample(n + ".lambda"), float)[1:]
        rv = evaluate(ref, n, frac[1:], "load") if n in ref["loads"] else 0.0
        d = np.abs(lv - rv) / scale
        k = int(np.argmax(d))
        if d[k] > out["multipliers"]:
            out["multipliers"] = float(d[k]); out["where"]["multipliers"] = (float(t[k + 1]), n)
    out["load_scale"] = scale
    out["ref_peak_load"] = float(ref["accuracy"]["peak_load"])
    out["T_lib"] = T
    return out


def cmd_run(problem, tol):
    import glob
    import models as M
    import ocp_constraints as oc
    base = problem.split("_")[0]          # "dpend_r3n40": the same problem, refined from the mesh Radau 3 x 40
    build = {"dpend": M.dpend, "pend": M.pend_force, "rp": M.rp, "ft": M.free_time}[base]
    method = oc.Radau(40, degree=3) if problem.endswith("_r3n40") else None
    pr = build()
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        sol = pr.solve(method, tolerance=float(tol))
    except Exception as exc:  # noqa: BLE001 - a crash is a finding
        print(json.dumps({"problem": problem, "tol": tol, "crash": f"{type(exc).__name__}: {str(exc)[:600]}",
                          "cpu": time.process_time() - c0}))
        return
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    mr = sol.mesh_refinement
    # every reference of the problem (local optima); the one nearest in objective is the one judged against
    refs = {os.path.basename(fn): with_body_states(base, np.load(fn, allow_pickle=True)["ref"].item())
            for fn in sorted(glob.glob(os.path.join(HERE, f"ref_{base}*.npz")))}
    errs = {k: errors(sol, base, r) for k, r in refs.items()}
    judged = min(refs, key=lambda k: abs(refs[k]["objective"] - float(sol.objective)))
    ref, e = refs[judged], errs[judged]
    est = {k: (float(v) if isinstance(v, (int, float)) else v) for k, v in (mr.get("estimate") or {}).items()}
    rec = {"problem": problem, "tol": tol, "met": bool(mr.get("met")), "message": str(mr.get("message")),
           "cpu": cpu, "wall": wall, "points": int(sol.transcription.scheme.point_count), "status": sol.status,
           "solves": len(mr.get("history", [])), "estimate": est, "true": e,
           "ratio": {k: (e[k] / est[k] if isinstance(est.get(k), float) and est[k] > 0 else None)
                     for k in ("states", "multipliers")},
           "objective": float(sol.objective), "objective_ref": ref["objective"], "T_ref": ref["T"],
           "reference": judged, "true_against_each": {k: {"objective_ref": refs[k]["objective"], "states": v["states"],
                                                          "multipliers": v["multipliers"], "states_joint": v["states_joint"]}
                                                     for k, v in errs.items()},
           "coordinates": mr.get("coordinates"), "ref_accuracy": ref["accuracy"],
           "bounds_passed_between_points": mr.get("bounds_passed_between_points"),
           "nonsmooth_intervals": mr.get("nonsmooth_intervals")}
    if base == "pend":
        tt = np.linspace(0, sol.t_final, 40001)
        F = np.hypot(sol.interpolate("hinge.v1.lambda", tt), sol.interpolate("hinge.v2.lambda", tt))
        Fp = np.hypot(sol.sample("hinge.v1.lambda"), sol.sample("hinge.v2.lambda"))[1:]
        rec["path"] = {"F_max": M.PF["F_max"], "max_F_points": float(Fp.max()), "max_F_interp": float(F.max())}
    if base == "rp":
        tt = np.linspace(0, sol.t_final, 40001)
        p = np.asarray(sol.interpolate("arm.psi", tt))
        rec["bound"] = {"psi_max": M.RP["psi_max"], "max_points": float(np.max(sol.sample("arm.psi"))),
                        "max_interp": float(p.max())}
    print(json.dumps(rec, default=str))


def cmd_all(problems):
    for p in problems:
        for tol in TOLS:
            cap = lambda: resource.setrlimit(resource.RLIMIT_CPU, (CPU_CAP, CPU_CAP + 5))
            c0 = time.time()
            try:
                out = subprocess.run([sys.executable, os.path.abspath(__file__), "run", p, tol], capture_output=True,
                                     text=True, timeout=WALL_CAP, preexec_fn=cap, cwd=HERE)
                line = (out.stdout.strip().splitlines() or [""])[-1]
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:
                    why = "CPU cap 120 s (SIGXCPU)" if out.returncode in (-24, -9) else f"exit {out.returncode}"
                    rec = {"problem": p, "tol": tol, "crash": f"{why}: {out.stderr.strip()[-400:]}"}
            except subprocess.TimeoutExpired:
                rec = {"problem": p, "tol": tol, "crash": f"wall timeout {WALL_CAP} s"}
            rec["wall_total"] = time.time() - c0
            with open(os.path.join(HERE, "results.jsonl"), "a") as fh:
                fh.write(json.dumps(rec, default=str) + "\n")
            short = {k: rec.get(k) for k in ("problem", "tol", "met", "points", "cpu", "estimate", "ratio", "crash")}
            print(json.dumps(short, default=str)[:500], flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "run":
        cmd_run(sys.argv[2], sys.argv[3])
    elif sys.argv[1] == "all":
        cmd_all(sys.argv[2:] or ["dpend", "pend", "rp", "ft"])
