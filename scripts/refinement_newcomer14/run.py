"""Runner (pattern of scripts/refinement_newcomer12/run.py), free final time.

    python run.py one NAME TOL [--eps E] [--coords maximal]   # one refined solve in this process; prints ROW {json}
    python run.py fixed NAME N DEGREE [--eps E] [--coords C]   # a uniform Radau mesh, cold; prints ROW {json}
    python run.py all NAME [TOL ...] [--eps E] [--coords C] [--mesh-at f1,f2]   # --mesh-at: first mesh Radau 5 x 10
                                                              # plus points at these fractions of the horizon; each TOL in its own subprocess (RLIMIT_CPU 200 s,
                                                              # wall kill 290 s), one at a time; appends runs_*.jsonl

Errors at NORMALISED times s (the solution at s T_sol against the reference at s T_ref): 16 per final mesh interval
+ 4001 evenly spaced + 1e-9 either side of each reference junction (normalised by T_ref), via sol.interpolate.
States: every body coordinate, rate and speed in sol.sample_names() (absolute SI); plus |T_sol - T_ref| separately
and `true_states_with_T` = max of the two. Multipliers: every "*.lambda" divided by mesh_refinement["load_scale"].
Inputs: relative to the reference's largest |input|.
"""
from __future__ import annotations

import json
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
CPU_CAP, WALL_CAP = 200, 290


def library_id():
    """where ocp_constraints was imported from, and a sha1 of its *.py files (the library was being edited by
    another engineer during this check: every row records which state it ran against)."""
    import hashlib
    import os
    import ocp_constraints
    root = Path(ocp_constraints.__file__).resolve().parent
    h = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode()); h.update(f.read_bytes())
    return dict(library_path=str(root), library_sha1=h.hexdigest()[:12])


def errors(sol, name, eps, s, load_scale=None):
    import reference
    st, lam, inp, info = reference.evaluate(name, s, eps)
    Tref, Tsol = info["T"], float(sol.t_final)
    tt = s * Tsol
    names = set(sol.sample_names())
    e = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v) for k, v in st.items() if k in names}
    ws = max(e, key=lambda k: e[k].max())
    ls = load_scale or info["load_scale"]
    le = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v) for k, v in lam.items() if k in names}
    wl = max(le, key=lambda k: le[k].max())
    ue = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v) / max(np.abs(v).max(), 1e-300)
          for k, v in inp.items()}
    wu = max(ue, key=lambda k: ue[k].max())
    # away from the reference's junctions (outside +-1e-3 of the horizon)
    away = np.ones_like(s, bool)
    for j in info["junctions"]:
        away &= np.abs(s - j / Tref) > 1e-3
    missing = sorted(set(st) - names) + sorted(set(lam) - names)
    extra = sorted(k for k in names if k.endswith(".lambda") and k not in lam)
    terr = abs(Tsol - Tref)
    return dict(T_sol=Tsol, T_ref=Tref, true_T=terr,
                true_states=float(e[ws].max()), worst_state=ws, worst_state_s=float(s[e[ws].argmax()]),
                true_states_with_T=max(float(e[ws].max()), terr),
                true_mult=float(le[wl].max()) / ls, worst_mult=wl, worst_mult_s=float(s[le[wl].argmax()]),
                true_mult_away=max(float(le[k][away].max()) for k in le) / ls,
                true_inputs=float(ue[wu].max()), worst_input_s=float(s[ue[wu].argmax()]),
                true_inputs_away=float(max(ue[k][away].max() for k in ue)),
                missing=missing, unchecked_lambdas=extra, ref_objective=float(info["objective"]),
                ref_load_scale=float(info["load_scale"]), ref_junctions=[float(j) for j in info["junctions"]])


def sample_s(name, eps, mesh_frac):
    import reference
    _, _, _, info = reference.evaluate(name, np.array([0.0, 1.0]), eps)
    T = info["T"]
    s = np.concatenate([np.linspace(mesh_frac[k], mesh_frac[k + 1], 17)[:-1] for k in range(len(mesh_frac) - 1)]
                       + [np.linspace(0, 1, 4001)] + [[j / T - 1e-9, j / T + 1e-9] for j in info["junctions"]])
    return np.unique(np.clip(s, 0, 1))


def one(name, tol, eps=None, coords=None, mesh_at=None):
    import models
    import ocp_constraints as oc
    pb, P = models.build(name, eps, coords)
    t0 = time.process_time(); w0 = time.time()
    if mesh_at:          # the message's advice: a mesh point at each switch (fractions of the horizon)
        fr = np.unique(np.concatenate([np.linspace(0, 1, 11), np.asarray(mesh_at, float)]))
        sol = pb.solve(oc.Radau(len(fr) - 1, mesh=tuple(fr), degree=5), tolerance=tol)
    else:
        sol = pb.solve(tolerance=tol)
    cpu, wall = time.process_time() - t0, time.time() - w0
    mr = sol.mesh_refinement
    mesh = np.asarray(mr["mesh"], float)
    est = mr.get("estimate") or {}
    degs = mr.get("degrees")
    row = dict(name=name, tol=tol, eps=P["eps"], coords=coords, mesh_at=mesh_at, nlp_coordinates=getattr(pb, "nlp_coordinates", None),
               met=mr.get("met"), message=mr.get("message"),
               points=int(sum(degs)) + 1 if degs is not None else None, intervals=len(mesh) - 1,
               refinements=len(mr.get("history") or []), cpu_s=cpu, wall_s=wall,
               total_time_s=mr.get("total_time_s"), total_cpu_s=mr.get("total_cpu_s"),
               est_states=est.get("states"), est_mult=est.get("multipliers"), est_inputs=est.get("inputs"),
               est_t_final=est.get("t_final"), estimate=est,
               load_scale=mr.get("load_scale"), objective=sol.objective, success=sol.success, status=sol.status,
               input_arcs=mr.get("input_arcs"), switches_located=mr.get("switches_located"),
               jump_windows=mr.get("jump_windows"), restarted=bool(mr.get("restarted")),
               optimum_changed=mr.get("optimum_changed"), returned_refinement=mr.get("returned_refinement"),
               bounds_passed_between_points=mr.get("bounds_passed_between_points"),
               history=[dict(points=(int(sum(h["degrees"])) + 1 if h.get("degrees") is not None else None),
                             iters=h.get("iterations"), obj=h.get("objective"), est=h.get("estimate"),
                             cpu=h.get("cpu_s", h.get("cpu")))
                        for h in (mr.get("history") or [])])
    row.update(errors(sol, name, eps, sample_s(name, eps, mesh), mr.get("load_scale")))
    row.update(library_id())
    for k, e, tr in (("states", row["est_states"], row["true_states"]),
                     ("T", row["est_t_final"], row["true_T"]),
                     ("multipliers", row["est_mult"], row["true_mult"]),
                     ("inputs", row["est_inputs"], row["true_inputs"])):
        row[f"ratio_{k}"] = (tr / e) if e else None
    print("ROW " + json.dumps(row, default=str), flush=True)


def fixed(name, N, deg, eps=None, coords=None):
    import models
    import ocp_constraints as oc
    pb, P = models.build(name, eps, coords)
    t0 = time.process_time()
    sol = pb.solve(oc.Radau(int(N), degree=int(deg)))
    cpu = time.process_time() - t0
    mesh = np.linspace(0, 1, int(N) + 1)
    row = dict(name=name, N=int(N), degree=int(deg), points=int(N) * int(deg) + 1, cpu_s=cpu, success=sol.success,
               status=sol.status, objective=sol.objective, eps=P["eps"], coords=coords)
    row.update(errors(sol, name, eps, sample_s(name, eps, mesh)))
    row.update(library_id())
    print("ROW " + json.dumps(row, default=str), flush=True)


def _limit():
    resource.setrlimit(resource.RLIMIT_CPU, (CPU_CAP, CPU_CAP))


def run_all(name, tols, extra=(), tag=""):
    out = HERE / f"runs_{name}{tag}.jsonl"
    for tol in tols:
        t0 = time.time()
        p = subprocess.Popen(["timeout", "-s", "KILL", str(WALL_CAP), sys.executable, str(HERE / "run.py"), "one",
                              name, str(tol), *extra],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=_limit, cwd=HERE)
        so, se = p.communicate()
        rows = [json.loads(l[4:]) for l in so.splitlines() if l.startswith("ROW ")]
        status = f"rc {p.returncode}" + (" (SIGKILL: wall 290 s)" if p.returncode == 137 else "") + \
                 (" (SIGXCPU: CPU 200 s)" if p.returncode in (-24, 152) else "")
        row = rows[0] if rows else dict(name=name, tol=float(tol), met=None, error=status, stderr_tail=se[-4000:])
        row["rc"] = p.returncode; row["wall_total_s"] = time.time() - t0; row["extra"] = list(extra)
        with open(out, "a") as fh:
            fh.write(json.dumps(row, default=str) + "\n")
        print(name, tol, *extra, "met", row.get("met"), "pts", row.get("points"), "cpu", row.get("cpu_s"),
              "T", row.get("T_sol"), row.get("T_ref"),
              "est", row.get("est_states"), row.get("est_t_final"), row.get("est_mult"),
              "true", row.get("true_states"), row.get("true_T"), row.get("true_mult"), row.get("true_inputs"),
              "ratios", row.get("ratio_states"), row.get("ratio_T"), row.get("ratio_multipliers"),
              row.get("error", ""), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    eps, coords = None, None
    if "--eps" in args:
        i = args.index("--eps"); eps = float(args[i + 1]); del args[i:i + 2]
    if "--coords" in args:
        i = args.index("--coords"); coords = args[i + 1]; del args[i:i + 2]
    mesh_at = None
    if "--mesh-at" in args:                     # --mesh-at f1,f2 (fractions of the horizon)
        i = args.index("--mesh-at"); mesh_at = [float(x) for x in args[i + 1].split(",")]; del args[i:i + 2]
    if args[0] == "one":
        one(args[1], float(args[2]), eps, coords, mesh_at)
    elif args[0] == "fixed":
        fixed(args[1], args[2], args[3], eps, coords)
    else:
        extra = ((["--eps", repr(eps)] if eps is not None else []) + (["--coords", coords] if coords else [])
                 + (["--mesh-at", ",".join(map(repr, mesh_at))] if mesh_at else []))
        tag = (f"_eps{eps:g}" if eps is not None else "") + (f"_{coords}" if coords else "") + \
              ("_meshat" if mesh_at else "")
        run_all(args[1], [float(x) for x in (args[2:] or ["1e-4", "1e-5", "1e-6", "1e-7"])], extra, tag)
