"""Runner (pattern of scripts/refinement_newcomer10/run.py).

    python run.py one NAME TOL                 # one refined solve; prints ROW {json}
    python run.py all NAME [TOL ...] [--cap S] # each TOL in its own subprocess, RLIMIT_CPU S (default 200),
                                               # wall 290 s then SIGKILL, one at a time -> runs_NAME.jsonl
    python run.py uniform NAME N DEGREE        # one fixed Radau mesh, its true error; prints UNI {json}
    python run.py uniform_all NAME             # ladder of fixed meshes -> uniform_NAME.jsonl

True errors on 16 times per final mesh interval + 4001 evenly spaced times (+ 1e-9 either side of each reference
junction), through sol.interpolate. States: every body coordinate and speed (absolute, SI). Multipliers: the joint
forces F = problem.joint_force(channel) evaluated from the interpolated multipliers and coordinates, compared with
the reference's joint forces, plus every multiplier not in any joint force (moment components; zero in these
planar / straight-line problems); divided by mesh_refinement["load_scale"] (uniform runs: the reference's largest
load). Inputs: relative to the reference's largest input.
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

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def lib_forces(pr, sol, t):
    """Joint forces (fixed basis) of every load channel at times t, from the library's interpolated values."""
    names = sol.sample_names()
    lam_names = [n for n in names if n.endswith(".lambda")]
    assert len(lam_names) == pr.lam.shape[0], (lam_names, pr.lam.shape)
    sym_to_name = {}
    for k, n in enumerate(lam_names):
        sym_to_name[str(pr.lam[k])] = n
    for n in names:
        if n.endswith(".lambda") or n in pr.model.inputs:
            continue
        try:
            q = pr.quantity(n)
        except Exception:   # noqa: BLE001
            continue
        if q.is_symbolic():
            sym_to_name.setdefault(str(q), n)
    out, used = {}, set()
    for ch in [c.prefix for c in pr.eqs.load_channels]:
        F = pr.joint_force(ch)
        syms = ca.symvar(F)
        f = ca.Function("f", syms, [F])
        args = []
        for s in syms:
            n = sym_to_name[str(s)]
            if n.endswith(".lambda"):
                used.add(n)
            args.append(np.asarray(sol.interpolate(n, t), float))
        val = np.asarray(f(*[a[None, :] for a in args]), float) if syms else np.zeros((3, len(t)))
        val = np.broadcast_to(val, (3, len(t)))
        for i, c in enumerate("xyz"):
            out[f"{ch}.F_{c}"] = val[i]
    rest = {n: np.asarray(sol.interpolate(n, t), float) for n in lam_names if n not in used}
    return out, rest


LAST = {}   # the last true_errors' library values on its time grid (saved by cmd_one as sol_NAME_TOL.npz)


def true_errors(name, pr, sol, mesh_frac, load_scale):
    import truth
    T = float(pr.t_final)   # fixed horizons only in this check
    mesh = np.asarray(mesh_frac, float)
    s = np.concatenate([np.linspace(mesh[k], mesh[k + 1], 17)[:-1] for k in range(len(mesh) - 1)]
                       + [np.linspace(0, 1, 4001)] + [[j / T - 1e-9, j / T + 1e-9] for j in truth.junctions(name)])
    t = np.unique(np.clip(s, 0, 1)) * T
    st, loads, inp = truth.ref(name, t)
    serr = {k: np.abs(np.asarray(sol.interpolate(k, t), float) - v) for k, v in st.items()}
    w = max(serr, key=lambda k: serr[k].max())
    out = {"true_states": float(serr[w].max()), "worst_state": w, "worst_state_t": float(t[serr[w].argmax()]),
           "true_states_by": {k: float(v.max()) for k, v in serr.items() if v.max() > 0}}
    F, rest = lib_forces(pr, sol, t)
    LAST.clear()
    LAST.update({"t": t} | {f"lib:{k}": np.asarray(sol.interpolate(k, t), float) for k in st}
                | {f"libF:{k}": v for k, v in F.items()} | {f"librest:{k}": v for k, v in rest.items()}
                | {f"libu:{k}": np.asarray(sol.interpolate(k, t), float) for k in inp})
    lerr = {k: np.abs(F[k] - loads[k]) for k in loads if k in F}
    lerr.update({k: np.abs(v) for k, v in rest.items()})   # moment multipliers: zero in these problems
    ref_largest = max(float(np.abs(v).max()) for v in loads.values())
    scale = load_scale or ref_largest
    lw = max(lerr, key=lambda k: lerr[k].max())
    out.update(true_multipliers=float(lerr[lw].max()) / scale, worst_multiplier=lw,
               worst_multiplier_t=float(t[lerr[lw].argmax()]), ref_largest_load=ref_largest,
               true_multipliers_by={k: float(v.max()) / scale for k, v in lerr.items()})
    inner = (t > 0) & (t < T)     # the same without the two end points t = 0 and t = T
    out.update(true_multipliers_inner=max(float(v[inner].max()) for v in lerr.values()) / scale,
               true_multipliers_t0=max(float(v[0]) for v in lerr.values()) / scale,
               true_multipliers_tT=max(float(v[-1]) for v in lerr.values()) / scale,
               true_states_inner=max(float(v[inner].max()) for v in serr.values()))
    uerr = {k: np.abs(np.asarray(sol.interpolate(k, t), float) - v) / float(np.abs(v).max()) for k, v in inp.items()}
    uw = max(uerr, key=lambda k: uerr[k].max())
    out.update(true_inputs=float(uerr[uw].max()), worst_input=uw, worst_input_t=float(t[uerr[uw].argmax()]),
               true_inputs_inner=max(float(v[inner].max()) for v in uerr.values()))
    out["ref_uncertainty"] = truth.uncertainty(name)
    return out


def cmd_one(name, tol):
    import models
    pr = models.build(name)
    t0, w0 = time.process_time(), time.time()
    try:
        sol = pr.solve(tolerance=tol, progress=False)
    except Exception as e:  # noqa: BLE001 - a finding
        import traceback
        print("ROW " + json.dumps({"problem": name, "tol": tol, "exception": f"{type(e).__name__}: {e}"[:3000],
                                   "cpu_s": time.process_time() - t0}), flush=True)
        traceback.print_exc()
        return
    cpu, wall = time.process_time() - t0, time.time() - w0
    r = sol.mesh_refinement
    row = {"problem": name, "tol": tol, "met": r["met"], "message": r["message"],
           "points": r["history"][-1].get("points"), "intervals": r["history"][-1].get("intervals"),
           "mesh_points_final": len(r["mesh"]) - 1, "refinements": len(r["history"]) - 1, "solves": len(r["history"]),
           "cpu_s": cpu, "wall_solve_s": wall, "total_time_s": r.get("total_time_s"), "total_cpu_s": r.get("total_cpu_s"),
           "estimate": r.get("estimate"), "load_scale": r.get("load_scale"), "objective": sol.objective,
           "degrees_max": max(r["degrees"]) if r.get("degrees") else None,
           "switches_located": r.get("switches_located"), "input_arcs": r.get("input_arcs"),
           "returned_refinement": r.get("returned_refinement"),
           "history_points": [h.get("points") for h in r["history"]],
           "history_estimates": [h.get("estimate") for h in r["history"]],
           "history_objectives": [h.get("objective") for h in r["history"]],
           "history_iterations": [h.get("iterations") for h in r["history"]],
           "bounds_passed": r.get("bounds_passed_between_points"), "nlp_coordinates": pr.nlp_coordinates,
           "mesh": list(r["mesh"]), "degrees": list(r["degrees"]) if r.get("degrees") else None}
    row.update(true_errors(name, pr, sol, r["mesh"], r.get("load_scale")))
    np.savez_compressed(HERE / f"sol_{name}_{tol:g}.npz", **LAST)
    print("ROW " + json.dumps(row, default=str), flush=True)


def _sub(args, cap, wall_cap=290):
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
        row["wall_s"], row["cap_s"] = wall, cap
        if err.strip():
            row["stderr_tail"] = err[-3000:]
        with (HERE / f"runs_{name}.jsonl").open("a") as f:
            f.write(json.dumps(row) + "\n")
        est = row.get("estimate") or {}
        print(json.dumps({k: row.get(k) for k in ("problem", "tol", "met", "points", "refinements", "total_time_s",
                                                  "true_states", "true_multipliers", "true_inputs", "killed",
                                                  "exception")} | {"est": est}, default=str), flush=True)


def cmd_uniform(name, N, degree):
    import models
    import ocp_constraints as oc
    pr = models.build(name)
    t0 = time.process_time()
    sol = pr.solve(oc.Radau(N, degree=degree), progress=False)
    cpu = time.process_time() - t0
    row = {"problem": name, "N": N, "degree": degree, "points": N * degree + 1, "cpu_s": cpu, "status": sol.status}
    row.update(true_errors(name, pr, sol, np.linspace(0, 1, N + 1), None))
    print("UNI " + json.dumps(row, default=str), flush=True)


def cmd_uniform_all(name, cap, Ns):
    for degree in (5,):
        for N in Ns:
            out, err, killed, wall = _sub(["uniform", name, str(N), str(degree)], cap)
            rows = [ln[4:] for ln in out.splitlines() if ln.startswith("UNI ")]
            row = json.loads(rows[0]) if rows else {"problem": name, "N": N, "degree": degree, "killed": killed,
                                                    "stderr_tail": err[-1500:]}
            with (HERE / f"uniform_{name}.jsonl").open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(json.dumps({k: row.get(k) for k in ("N", "degree", "points", "cpu_s", "true_states",
                                                      "true_multipliers", "true_inputs", "killed")}), flush=True)


if __name__ == "__main__":
    a = sys.argv[1:]
    cap = 200
    if "--cap" in a:
        i = a.index("--cap")
        cap = int(a[i + 1])
        del a[i:i + 2]
    if a[0] == "one":
        cmd_one(a[1], float(a[2]))
    elif a[0] == "all":
        cmd_all(a[1], [float(x) for x in a[2:]] or [1e-4, 1e-5, 1e-6], cap)
    elif a[0] == "uniform":
        cmd_uniform(a[1], int(a[2]), int(a[3]))
    elif a[0] == "uniform_all":
        cmd_uniform_all(a[1], cap, [int(x) for x in a[2:]] or [10, 20, 40, 80, 160])
