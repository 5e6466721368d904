"""Runner: refined solves against the stored references (ref_NAME.pkl from ``python truth.py NAME``).

    python run.py one NAME TOL [MAX_REFINEMENTS]    # one refined solve; prints ROW {json}
    python run.py all NAME [TOL ...] [--cap S]       # each TOL in its own subprocess, RLIMIT_CPU S (120), wall 300 s
                                                     # (SIGKILL), one at a time; appends to runs_NAME.jsonl
    python run.py uniform NAME N DEGREE              # one fixed Radau mesh (cold), its true error; prints UNI {json}
    python run.py uniform_all NAME                   # a ladder of fixed meshes -> uniform_NAME.jsonl

True errors: on 16 times per final mesh interval plus 4001 evenly spaced times (plus 1e-9 either side of each
reference junction), through sol.interpolate. States: every body coordinate and speed (absolute, SI units); for the
free body also the rotation matrix (from the library's quaternion, normalised). Multipliers: every constraint's
lambda, divided by mesh_refinement["load_scale"]. Free final time: compared at equal fractions of each horizon.
"""
from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def quat_R_np(qw, qx, qy, qz):
    n = qw**2 + qx**2 + qy**2 + qz**2
    s = 2 / n
    return {"R11": 1 - s * (qy * qy + qz * qz), "R12": s * (qx * qy - qz * qw), "R13": s * (qx * qz + qy * qw),
            "R21": s * (qx * qy + qz * qw), "R22": 1 - s * (qx * qx + qz * qz), "R23": s * (qy * qz - qx * qw),
            "R31": s * (qx * qz - qy * qw), "R32": s * (qy * qz + qx * qw), "R33": 1 - s * (qx * qx + qy * qy)}


def true_errors(name, sol, mesh_frac, load_scale):
    import truth
    ref = truth.Stored(name)
    T_ref = ref.T
    T_lib = float(getattr(sol, "t_final", None) or truth.horizon(name, ref))
    mesh = np.asarray(mesh_frac, float)
    s = np.concatenate([np.linspace(mesh[k], mesh[k + 1], 17)[:-1] for k in range(len(mesh) - 1)]
                       + [np.linspace(0, 1, 4001)] + [[j / T_ref - 1e-9, j / T_ref + 1e-9] for j in ref.junctions])
    s = np.unique(np.clip(s, 0, 1))
    st, lam, inp = truth.lib_quantities(name, s * T_ref, ref)
    tl = s * T_lib
    names = set(sol.sample_names())
    lib = {k: np.asarray(sol.interpolate(k, tl), float) for k in st if k in names}
    if "sat.qw" in lib:
        lib.update(quat_R_np(lib["sat.qw"], lib["sat.qx"], lib["sat.qy"], lib["sat.qz"]))
    out = {}
    serr = {k: np.abs(lib[k] - st[k]) for k in st if k in lib}
    missing = sorted(k for k in st if k not in lib)
    w = max(serr, key=lambda k: serr[k].max())
    out.update(true_states=float(serr[w].max()), worst_state=w, worst_state_t=float(tl[serr[w].argmax()]),
               missing_names=missing)
    if name.startswith("slew"):
        q = [k for k in serr if k.startswith("sat.q")]
        R = [k for k in serr if k.startswith("R")]
        om = [k for k in serr if k.startswith("sat.omega")]
        out.update(true_quat=max(float(serr[k].max()) for k in q), true_R=max(float(serr[k].max()) for k in R),
                   true_omega=max(float(serr[k].max()) for k in om))
        body = [k for k in serr if not k.startswith("R")]
        wb = max(body, key=lambda k: serr[k].max())
        out.update(true_states_body=float(serr[wb].max()), worst_state_body=wb)
    if lam:
        lerr = {k: np.abs(np.asarray(sol.interpolate(k, tl), float) - v) for k, v in lam.items() if k in names}
        lw = max(lerr, key=lambda k: lerr[k].max())
        ref_largest = max(float(np.abs(v).max()) for v in lam.values())
        scale = load_scale or ref_largest or 1.0   # all loads zero: absolute (N)
        out.update(true_multipliers=float(lerr[lw].max()) / scale, worst_multiplier=lw,
                   worst_multiplier_t=float(tl[lerr[lw].argmax()]), ref_largest_load=ref_largest)
    uerr = {k: np.abs(np.asarray(sol.interpolate(k, tl), float) - v) / max(1e-300, float(np.abs(v).max()))
            for k, v in inp.items()}
    uw = max(uerr, key=lambda k: uerr[k].max())
    out.update(true_inputs=float(uerr[uw].max()), worst_input=uw)
    if T_lib is not None:
        out.update(T_lib=T_lib, T_ref=T_ref, true_T=abs(T_lib - T_ref))
    out["ref_uncertainty"] = ref.uncertainty
    return out


def cmd_one(name, tol, max_refinements=None):
    import models
    pr = models.build(name)
    t0 = time.process_time()
    w0 = time.time()
    try:
        kw = {} if max_refinements is None else {"max_refinements": max_refinements}
        sol = pr.solve(tolerance=tol, progress=False, **kw)
    except Exception as e:  # noqa: BLE001 - a finding
        import traceback
        print("ROW " + json.dumps({"problem": name, "tol": tol, "exception": f"{type(e).__name__}: {e}"[:1500],
                                   "cpu_s": time.process_time() - t0}), flush=True)
        traceback.print_exc()
        return
    cpu = time.process_time() - t0
    wall = time.time() - w0
    r = sol.mesh_refinement
    est = r.get("estimate") or {}
    row = {"problem": name, "tol": tol, "max_refinements": max_refinements, "met": r["met"], "message": r["message"],
           "points": r["history"][-1].get("points"), "intervals": r["history"][-1].get("intervals"),
           "refinements": len(r["history"]), "cpu_s": cpu, "wall_solve_s": wall, "total_cpu_s": r.get("total_cpu_s"),
           "estimate": est, "load_scale": r.get("load_scale"), "objective": sol.objective,
           "degrees_max": max(r["degrees"]) if r.get("degrees") else None,
           "switches_located": r.get("switches_located"), "returned_refinement": r.get("returned_refinement"),
           "returned_points": (r["history"][r["returned_refinement"]]["points"] if r.get("returned_refinement")
                               is not None else None),
           "history_points": [h.get("points") for h in r["history"]],
           "history_estimates": [h.get("estimate") for h in r["history"]],
           "bounds_passed": r.get("bounds_passed_between_points"), "nlp_coordinates": pr.nlp_coordinates}
    row.update(true_errors(name, sol, r["mesh"], r.get("load_scale")))
    print("ROW " + json.dumps(row, default=str), flush=True)


def _sub(args, cap, wall_cap=300):
    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (cap, cap))
        os.setsid()
    w0 = time.time()
    p = subprocess.Popen([sys.executable, str(HERE / "run.py")] + args, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, preexec_fn=limit, cwd=HERE)
    try:
        out, err = p.communicate(timeout=wall_cap)
        killed = None if p.returncode == 0 else f"returncode {p.returncode}"
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        killed = f"wall timeout {wall_cap} s (SIGKILL)"
    return out, err, killed, time.time() - w0


def cmd_all(name, tols, cap):
    for tol in tols:
        out, err, killed, wall = _sub(["one", name, repr(tol)], cap)
        rows = [ln[4:] for ln in out.splitlines() if ln.startswith("ROW ")]
        row = json.loads(rows[0]) if rows else {"problem": name, "tol": tol, "killed": killed or "no row"}
        row["wall_s"] = wall
        row["cap_s"] = cap
        if err.strip():
            row["stderr_tail"] = err[-2000:]
        with (HERE / f"runs_{name}.jsonl").open("a") as f:
            f.write(json.dumps(row) + "\n")
        print(json.dumps({k: row.get(k) for k in ("problem", "tol", "met", "points", "cpu_s", "estimate",
                                                  "true_states", "true_multipliers", "killed", "exception")},
                         default=str), flush=True)


def cmd_uniform(name, N, degree):
    import models
    import ocp_constraints as oc
    pr = models.build(name)
    t0 = time.process_time()
    try:
        sol = pr.solve(oc.Radau(N, degree=degree), progress=False)
    except Exception as e:  # noqa: BLE001
        print("UNI " + json.dumps({"problem": name, "N": N, "degree": degree, "exception": str(e)[:300]}))
        return
    cpu = time.process_time() - t0
    mesh = np.linspace(0, 1, N + 1)
    row = {"problem": name, "N": N, "degree": degree, "points": N * degree + 1, "cpu_s": cpu,
           "status": sol.status}
    row.update(true_errors(name, sol, mesh, None))   # multipliers relative to the reference's largest load
    row.pop("ref_uncertainty", None)
    print("UNI " + json.dumps(row, default=str), flush=True)


def cmd_uniform_all(name, cap=120):
    for degree in (5, 7):
        for N in (10, 20, 40, 80, 160, 320):
            out, err, killed, wall = _sub(["uniform", name, str(N), str(degree)], cap)
            rows = [ln[4:] for ln in out.splitlines() if ln.startswith("UNI ")]
            row = json.loads(rows[0]) if rows else {"problem": name, "N": N, "degree": degree, "killed": killed}
            with (HERE / f"uniform_{name}.jsonl").open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(json.dumps({k: row.get(k) for k in ("N", "degree", "cpu_s", "true_states", "true_multipliers",
                                                      "killed", "exception")}), flush=True)
            if killed or (row.get("true_states", 1) < 1e-8 and row.get("true_multipliers", 0) < 1e-8):
                break


if __name__ == "__main__":
    a = sys.argv[1:]
    cap = 120
    if "--cap" in a:
        i = a.index("--cap")
        cap = int(a[i + 1])
        del a[i:i + 2]
    if a[0] == "one":
        cmd_one(a[1], float(a[2]), int(a[3]) if len(a) > 3 else None)
    elif a[0] == "all":
        cmd_all(a[1], [float(x) for x in a[2:]] or [1e-3, 1e-4, 1e-5, 1e-6, 1e-7], cap)
    elif a[0] == "uniform":
        cmd_uniform(a[1], int(a[2]), int(a[3]))
    elif a[0] == "uniform_all":
        cmd_uniform_all(a[1], cap)
