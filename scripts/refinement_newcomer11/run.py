"""Runner: refined solves against the stored references (ref_NAME.pkl from ``python reference.py NAME``).

    python run.py one NAME TOL            # one refined solve in this process; prints ROW {json}
    python run.py all NAME [TOL ...]      # each TOL in its own subprocess (RLIMIT_CPU 120 s, wall kill 300 s),
                                          # one at a time; appends to runs_NAME.jsonl

True errors on 16 times per final mesh interval + 4001 evenly spaced times + 1e-9 either side of each reference
junction, via sol.interpolate. States: every body coordinate and speed in sol.sample_names() (absolute SI).
Multipliers: every "*.lambda", divided by mesh_refinement["load_scale"].
"""
from __future__ import annotations

import json
import pickle
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def one(name, tol, start=None, refname=None):
    import models
    import ocp_constraints as oc
    import reference
    pb, P = models.build(name)
    t0 = time.process_time(); w0 = time.time()
    if start:                                  # a first mesh of our own: Radau(N, degree)
        sol = pb.solve(oc.Radau(int(start[0]), degree=int(start[1])), tolerance=tol)
    else:
        sol = pb.solve(tolerance=tol)
    cpu, wall = time.process_time() - t0, time.time() - w0
    mr = sol.mesh_refinement
    refname = refname or name
    if not (HERE / f"ref_{refname}.pkl").exists():     # no reference yet: the library's side alone
        est = mr.get("estimate") or {}
        print("ROW " + json.dumps(dict(name=name, tol=tol, met=mr.get("met"), message=mr.get("message"),
              points=int(sum(mr["degrees"])) + 1 if mr.get("degrees") is not None else None,
              intervals=len(mr.get("mesh") or []) - 1, cpu_s=cpu, wall_s=wall, total_cpu_s=mr.get("total_cpu_s"),
              est_states=est.get("states"), est_mult=est.get("multipliers"), input_arcs=mr.get("input_arcs"),
              objective=sol.objective, no_reference=True), default=str), flush=True)
        return
    ref = pickle.load(open(HERE / f"ref_{refname}.pkl", "rb"))
    T = float(sum(ref["durations"]))
    mesh = np.asarray(mr["mesh"], float) * T
    tt = np.concatenate([np.linspace(mesh[k], mesh[k + 1], 17)[:-1] for k in range(len(mesh) - 1)]
                        + [np.linspace(0, T, 4001)] + [[j - 1e-9, j + 1e-9] for j in ref["junctions"]])
    tt = np.unique(np.clip(tt, 0, T))
    st, lam, inp, path = reference.evaluate(ref, tt)
    names = set(sol.sample_names())
    serr = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v).max() for k, v in st.items() if k in names}
    missing = sorted(k for k in st if k not in names)
    ws = max(serr, key=serr.get)
    ls = mr.get("load_scale") or 1.0
    lerr = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v) for k, v in lam.items() if k in names}
    wl = max(lerr, key=lambda k: lerr[k].max())
    uerr = {k: np.abs(np.asarray(sol.interpolate(k, tt), float) - v).max() / np.abs(v).max() for k, v in inp.items()}
    est = mr.get("estimate") or {}
    n_points = None
    if mr.get("mesh") is not None:
        degs = mr.get("degrees")
        n_points = int(sum(degs)) + 1 if degs is not None else None
    row = dict(name=name, tol=tol, met=mr.get("met"), message=mr.get("message"), points=n_points,
               intervals=len(mesh) - 1, cpu_s=cpu, wall_s=wall, total_cpu_s=mr.get("total_cpu_s"),
               est_states=est.get("states"), est_mult=est.get("multipliers"), est_inputs=est.get("inputs"),
               load_scale=ls, ref_load_scale=ref["accuracy"]["load_scale"],
               true_states=float(serr[ws]), worst_state=ws, worst_state_t=None,
               true_mult=float(lerr[wl].max()) / ls, worst_mult=wl, worst_mult_t=float(tt[lerr[wl].argmax()]),
               true_inputs=max(uerr.values()), missing=missing,
               input_arcs=mr.get("input_arcs"), ref_junctions=[float(j) for j in ref["junctions"]],
               ref_phases=ref["phases"], objective=sol.objective, ref_objective=ref["objective"],
               refinements=len(mr.get("history") or []), start=start, refname=refname)
    for k in ("states", "multipliers"):
        e = row["est_states" if k == "states" else "est_mult"]
        tr = row["true_states" if k == "states" else "true_mult"]
        row[f"ratio_{k}"] = (tr / e) if e else None
    lib_j = sorted(x for a in (mr.get("input_arcs") or []) for x in (a.get("start"), a.get("end"))
                   if x is not None and 1e-12 < x < T - 1e-12)
    row["lib_junctions"] = lib_j
    if len(lib_j) == len(ref["junctions"]):
        row["junction_err"] = max(abs(a - b) for a, b in zip(lib_j, ref["junctions"])) if lib_j else 0.0
    print("ROW " + json.dumps(row, default=str), flush=True)


def _limit():
    resource.setrlimit(resource.RLIMIT_CPU, (120, 120))


def run_all(name, tols, extra=(), tag=""):
    out = HERE / f"runs_{name}{tag}.jsonl"
    for tol in tols:
        t0 = time.time()
        p = subprocess.Popen([sys.executable, str(HERE / "run.py"), "one", name, str(tol), *extra], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, preexec_fn=_limit, cwd=HERE)
        try:
            so, se = p.communicate(timeout=300)
            status = f"rc {p.returncode}"
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGKILL); so, se = p.communicate(); status = "wall kill 300 s"
        rows = [json.loads(l[4:]) for l in so.splitlines() if l.startswith("ROW ")]
        row = rows[0] if rows else dict(name=name, tol=float(tol), met=None, error=status, stderr_tail=se[-3000:])
        row["rc"] = p.returncode; row["wall_total_s"] = time.time() - t0
        if p.returncode not in (0, None) and rows == []:
            row["signal"] = status
        with open(out, "a") as fh:
            fh.write(json.dumps(row, default=str) + "\n")
        print(name, tol, row.get("met"), row.get("points"), row.get("cpu_s"), row.get("ratio_states"),
              row.get("ratio_multipliers"), row.get("error", ""), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    start = ref = None
    if "--start" in args:                      # --start N DEGREE: refine from Radau(N, degree)
        i = args.index("--start"); start = args[i + 1:i + 3]; del args[i:i + 3]
    if "--ref" in args:                        # --ref REFNAME: judge against ref_REFNAME.pkl
        i = args.index("--ref"); ref = args[i + 1]; del args[i:i + 2]
    if args[0] == "one":
        one(args[1], float(args[2]), start, ref)
    else:
        extra = (["--start", *start] if start else []) + (["--ref", ref] if ref else [])
        tag = (f"_start{start[0]}x{start[1]}" if start else "") + (f"_ref{ref}" if ref else "")
        run_all(args[1], [float(x) for x in (args[2:] or ["1e-4", "1e-5", "1e-6", "1e-7"])], extra, tag)
