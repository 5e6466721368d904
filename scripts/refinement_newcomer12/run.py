"""Runner (pattern of scripts/refinement_newcomer11/run.py).

    python run.py one NAME TOL [--reg W] [--coords maximal]   # one refined solve in this process; prints ROW {json}
    python run.py fixed NAME N DEGREE [--reg W]             # a uniform Radau mesh, cold; prints ROW {json}
    python run.py all NAME [TOL ...] [--reg W]              # each TOL in its own subprocess (RLIMIT_CPU 240 s,
                                                           # wall kill 290 s), one at a time; appends runs_NAME*.jsonl

True errors on 16 times per final mesh interval + 4001 evenly spaced times + 1e-9 either side of each reference
switch, via sol.interpolate. States: every body coordinate, rate and speed in sol.sample_names() (absolute SI).
Multipliers: every "*.lambda", divided by mesh_refinement["load_scale"] (uniform meshes: by the reference's).
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


def errors(sol, name, tt, ref_kw, load_scale=None, windows=None):
    import reference
    st, lam, inp, info = reference.evaluate(name, tt, **ref_kw)
    names = set(sol.sample_names())
    serr = {k: float(np.abs(np.asarray(sol.interpolate(k, tt), float) - v).max()) for k, v in st.items() if k in names}
    ws = max(serr, key=serr.get)
    ls = load_scale or info["load_scale"]
    lerr = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v) for k, v in lam.items() if k in names}
    wl = max(lerr, key=lambda k: lerr[k].max())
    # away from the switches (outside +-1e-3 s): where the multipliers' error is made off the jumps
    away = np.ones_like(tt, bool)
    for j in info["junctions"]:
        away &= np.abs(tt - j) > 1e-3
    lerr_away = max(float(lerr[k][away].max()) for k in lerr) / ls
    # outside the library's own jump windows (the part its multiplier estimate covers)
    out = np.ones_like(tt, bool)
    for a, b in (windows or []):
        out &= (tt < a) | (tt > b)
    lerr_out = max(float(lerr[k][out].max()) for k in lerr) / ls
    wl_out = max(lerr, key=lambda k: lerr[k][out].max())
    t_out = float(tt[out][lerr[wl_out][out].argmax()])
    uerr = {k: float(np.abs(np.asarray(sol.interpolate(k, tt), float) - v).max() / max(np.abs(v).max(), 1e-300))
            for k, v in inp.items()}
    missing = sorted(set(st) - names) + sorted(set(lam) - names)
    extra = sorted(k for k in names if k.endswith(".lambda") and k not in lam)
    return dict(true_states=serr[ws], worst_state=ws, worst_state_t=float(tt[np.abs(np.asarray(
                    sol.interpolate(ws, tt), float) - st[ws]).argmax()]),
                true_mult=float(lerr[wl].max()) / ls, worst_mult=wl, worst_mult_t=float(tt[lerr[wl].argmax()]),
                true_mult_away_1ms=lerr_away, true_mult_outside_windows=lerr_out, worst_mult_outside=wl_out,
                worst_mult_outside_t=t_out, true_inputs=max(uerr.values()) if uerr else None,
                missing=missing, unchecked_lambdas=extra, ref_objective=float(info["objective"]),
                ref_load_scale=float(info["load_scale"]), ref_junctions=[float(j) for j in info["junctions"]])


def sample_times(name, mesh_s, ref_kw):
    import reference
    from models import PARAMS
    T = PARAMS[name]["T"]
    _, _, _, info = reference.evaluate(name, np.array([0.0, T]), **ref_kw)
    tt = np.concatenate([np.linspace(mesh_s[k], mesh_s[k + 1], 17)[:-1] for k in range(len(mesh_s) - 1)]
                        + [np.linspace(0, T, 4001)] + [[j - 1e-9, j + 1e-9] for j in info["junctions"]])
    return np.unique(np.clip(tt, 0, T))


def one(name, tol, reg=0.0, coords=None, mesh_at=None):
    import models
    import ocp_constraints as oc
    pb, P = models.build(name, reg=reg, coordinates=coords)
    t0 = time.process_time(); w0 = time.time()
    if mesh_at:                     # the message's advice: a mesh point at each switch (fractions of the horizon)
        fr = np.unique(np.concatenate([np.linspace(0, 1, 11), np.asarray(mesh_at, float) / P["T"]]))
        sol = pb.solve(oc.Radau(len(fr) - 1, mesh=tuple(fr), degree=5), tolerance=tol)
    else:
        sol = pb.solve(tolerance=tol)
    cpu, wall = time.process_time() - t0, time.time() - w0
    mr = sol.mesh_refinement
    T = P["T"]
    mesh = np.asarray(mr["mesh"], float) * T
    est = mr.get("estimate") or {}
    degs = mr.get("degrees")
    row = dict(name=name, tol=tol, reg=reg, coords=coords, mesh_at=mesh_at, met=mr.get("met"), message=mr.get("message"),
               points=int(sum(degs)) + 1 if degs is not None else None, intervals=len(mesh) - 1,
               refinements=len(mr.get("history") or []), cpu_s=cpu, wall_s=wall,
               total_time_s=mr.get("total_time_s"), total_cpu_s=mr.get("total_cpu_s"),
               est_states=est.get("states"), est_mult=est.get("multipliers"), est_inputs=est.get("inputs"),
               load_scale=mr.get("load_scale"), objective=sol.objective, success=sol.success, status=sol.status,
               input_arcs=mr.get("input_arcs"), switches_located=mr.get("switches_located"),
               jump_windows=mr.get("jump_windows"), restarted=bool(mr.get("restarted")),
               history=[dict(points=(int(sum(h["degrees"])) + 1 if h.get("degrees") is not None else None),
                             iters=h.get("iterations"), obj=h.get("objective"), est=h.get("estimate"),
                             cpu=h.get("cpu_s", h.get("cpu")))
                        for h in (mr.get("history") or [])])
    rk = dict(reg=reg) if reg else {}
    tt = sample_times(name, mesh, rk)
    win = [(a * T, b * T) for a, b in (mr.get("jump_windows") or [])]
    row.update(errors(sol, name, tt, rk, mr.get("load_scale"), win))
    for k, e, tr in (("states", row["est_states"], row["true_states"]), ("multipliers", row["est_mult"], row["true_mult"]),
                     ("mult_outside_windows", row["est_mult"], row["true_mult_outside_windows"])):
        row[f"ratio_{k}"] = (tr / e) if e else None
    print("ROW " + json.dumps(row, default=str), flush=True)


def fixed(name, N, deg, reg=0.0, coords=None):
    import models
    import ocp_constraints as oc
    pb, P = models.build(name, reg=reg, coordinates=coords)
    t0 = time.process_time()
    sol = pb.solve(oc.Radau(int(N), degree=int(deg)))
    cpu = time.process_time() - t0
    mesh = np.linspace(0, P["T"], int(N) + 1)
    row = dict(name=name, N=int(N), degree=int(deg), points=int(N) * int(deg) + 1, cpu_s=cpu, success=sol.success,
               status=sol.status, objective=sol.objective, reg=reg)
    rk = dict(reg=reg) if reg else {}
    row.update(errors(sol, name, sample_times(name, mesh, rk), rk))
    print("ROW " + json.dumps(row, default=str), flush=True)


def _limit():
    resource.setrlimit(resource.RLIMIT_CPU, (240, 240))


def run_all(name, tols, extra=(), tag=""):
    out = HERE / f"runs_{name}{tag}.jsonl"
    for tol in tols:
        t0 = time.time()
        p = subprocess.Popen([sys.executable, str(HERE / "run.py"), "one", name, str(tol), *extra],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=_limit, cwd=HERE)
        try:
            so, se = p.communicate(timeout=290)
            status = f"rc {p.returncode}"
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGKILL); so, se = p.communicate(); status = "wall kill 290 s"
        rows = [json.loads(l[4:]) for l in so.splitlines() if l.startswith("ROW ")]
        row = rows[0] if rows else dict(name=name, tol=float(tol), met=None, error=status, stderr_tail=se[-4000:])
        row["rc"] = p.returncode; row["wall_total_s"] = time.time() - t0
        with open(out, "a") as fh:
            fh.write(json.dumps(row, default=str) + "\n")
        print(name, tol, "met", row.get("met"), "pts", row.get("points"), "cpu", row.get("cpu_s"),
              "est", row.get("est_states"), row.get("est_mult"), "true", row.get("true_states"), row.get("true_mult"),
              "ratios", row.get("ratio_states"), row.get("ratio_multipliers"), "outside win", row.get("ratio_mult_outside_windows"), row.get("error", ""), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    reg, coords = 0.0, None
    if "--reg" in args:
        i = args.index("--reg"); reg = float(args[i + 1]); del args[i:i + 2]
    if "--coords" in args:
        i = args.index("--coords"); coords = args[i + 1]; del args[i:i + 2]
    mesh_at = None
    if "--mesh-at" in args:                     # --mesh-at t1,t2 (s)
        i = args.index("--mesh-at"); mesh_at = [float(x) for x in args[i + 1].split(",")]; del args[i:i + 2]
    if args[0] == "one":
        one(args[1], float(args[2]), reg, coords, mesh_at)
    elif args[0] == "fixed":
        fixed(args[1], args[2], args[3], reg, coords)
    else:
        extra = ((["--reg", str(reg)] if reg else []) + (["--coords", coords] if coords else [])
                 + (["--mesh-at", ",".join(map(repr, mesh_at))] if mesh_at else []))
        tag = (f"_reg{reg:g}" if reg else "") + (f"_{coords}" if coords else "") + ("_meshat" if mesh_at else "")
        run_all(args[1], [float(x) for x in (args[2:] or ["1e-4", "1e-5", "1e-6"])], extra, tag)
