"""Ninth newcomer check of accuracy on request (issue 19): TRACKING problems through `problem.track`.

    python nc9.py ref NAME                 # reference at sub = 1 and 2 (own accuracy), saved to ref_NAME.npz
    python nc9.py probe NAME               # one fixed-mesh solve: conventions (hinge, basis), objective vs reference
    python nc9.py one NAME TOL [--maxref K] [--start N,DEG]   # one refined solve IN THIS PROCESS, one JSON line;
                                           # --start: refine from oc.Radau(N, degree=DEG) instead of the default
    python nc9.py all NAME [TOL ...] [--cap S] [--maxref K] [--start N,DEG]  # each TOL in its own subprocess, RLIMIT_CPU cap (default 120 s),
                                           # one at a time -> runs_NAME.jsonl
    python nc9.py fixed NAME N DEG         # one uniform Radau(N, degree=DEG) solve in this process, JSON line
    python nc9.py uniform NAME [DEG]       # the sweep of uniform meshes, each in a subprocess -> uniform_NAME.jsonl

Problems (all: rod 1 kg, 1 m, pinned at its end, gravity 9.81 along -E2, motor torque about E3, T = 2 s,
starts at rest hanging down, final state free, min int 1000 (psi - r(t))^2 + tau^2 dt):
    smooth      r(t) = 0.2 + 0.5 sin(pi t)                          (ca.sin of the CasADi time)
    pl          np.interp(t, tk, r(tk)), tk every 0.02 s (50 Hz)   (np.interp on the CasADi time works here)
    spline      CubicSpline(tk, r(tk) + N(0, 1e-3) noise, seed 9), written as a CasADi piecewise cubic
    smooth_max  `smooth` with OptimalControlProblem(..., coordinates="maximal")
    pl_max      `pl` with coordinates="maximal"
    NAME_wK     tracking weight 10^K instead of 1000 (pl_w5, spline_w5, smooth_w5, pl_w7, ...: tight tracking,
                the torque follows r'' more closely, the kinks at the 50 Hz samples show more)
"""
from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

import ocp_constraints as oc
import reference as R

HERE = Path(__file__).resolve().parent
TOLS = [1e-3, 1e-4, 1e-5, 1e-6]
TK = np.linspace(0.0, R.T, int(round(R.T / R.DT_SAMPLE)) + 1)
NOISE = np.random.default_rng(9).normal(0.0, 1e-3, TK.size)


def r_smooth(t):
    return 0.2 + 0.5 * np.sin(np.pi * np.asarray(t, float))


SPLINE = CubicSpline(TK, r_smooth(TK) + NOISE)


def base_of(name: str) -> str:
    return re.sub(r"_w\d+", "", name.replace("_max", ""))


def weight_of(name: str) -> float:
    m = re.search(r"_w(\d+)", name)
    return 10.0 ** int(m.group(1)) if m else R.W


def r_numeric(name: str):
    base = base_of(name)
    if base == "smooth":
        return r_smooth
    if base == "pl":
        return lambda t: np.interp(t, TK, r_smooth(TK))
    if base == "spline":
        return lambda t: SPLINE(np.asarray(t, float))
    raise SystemExit(f"unknown problem {name}")


def spline_casadi(t):
    """The scipy CubicSpline, piece by piece, as a CasADi expression (SPLINE(t) itself gives NaN on an SX)."""
    c = SPLINE.c                                  # 4 x (n-1): c[0] (t-tk)^3 + ... + c[3]
    breaks = ca.DM(TK[1:-1])
    pick = lambda v: ca.pw_const(t, breaks, ca.DM(v))
    dt = t - pick(TK[:-1])
    return ((pick(c[0]) * dt + pick(c[1])) * dt + pick(c[2])) * dt + pick(c[3])


def r_casadi(name: str):
    base = base_of(name)
    if base == "smooth":
        return lambda t: 0.2 + 0.5 * ca.sin(np.pi * t)
    if base == "pl":
        samples = r_smooth(TK)
        return lambda t: np.interp(t, TK, samples)
    if base == "spline":
        return spline_casadi
    raise SystemExit(f"unknown problem {name}")


def build(name: str):
    model = oc.Model("rod", gravity=(0.0, -R.G, 0.0))
    rod = model.add_body("rod", R.M, R.M * R.L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, R.L / 2, 0.0]), axis=(0, 0, 1))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    kw = {"coordinates": "maximal"} if name.endswith("_max") else {}
    problem = oc.OptimalControlProblem(model, t_final=R.T, **kw)
    problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    problem.track("rod.psi", r_casadi(name), weight_of(name))
    problem.minimize_effort(["motor"])
    return problem


# ---------------------------------------------------------------------------------------------------- reference
def ref_path(name: str) -> Path:
    return HERE / f"ref_{name.replace('_max', '')}.npz"     # NAME_w5 keeps its own file


def load_ref(name: str) -> dict:
    d = np.load(ref_path(name))
    return {k: (d[k] if d[k].ndim else d[k].item()) for k in d.files}


def cmd_ref(name: str) -> None:
    rn = r_numeric(name)
    out = {}
    for sub in (1, 2):
        c0 = time.process_time()
        out[sub] = R.solve(rn, sub=sub, W=weight_of(name))
        print(f"sub {sub}: {out[sub]['mesh'].size - 1} intervals x degree {R.DEG}, J = {out[sub]['J']:.12f}, "
              f"CPU {time.process_time() - c0:.1f} s")
    t = dense_grid(out[1]["mesh"], 16)
    a, b = R.evaluate(out[1], t), R.evaluate(out[2], t)
    scale = np.max(np.hypot(b["Fx"], b["Fy"]))
    print(f"sub 1 vs 2 on {t.size} times: psi {np.max(abs(a['psi'] - b['psi'])):.1e} rad, "
          f"w {np.max(abs(a['w'] - b['w'])):.1e} rad/s, tau {np.max(abs(a['tau'] - b['tau'])):.1e} N m, "
          f"F {max(np.max(abs(a['Fx'] - b['Fx'])), np.max(abs(a['Fy'] - b['Fy']))):.1e} N "
          f"(largest |F| {scale:.3f} N), J {abs(out[1]['J'] - out[2]['J']):.1e}")
    np.savez(ref_path(name), **{k: v for k, v in out[2].items()})


def dense_grid(mesh: np.ndarray, per: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, per + 1)[:-1]
    return np.unique(np.concatenate([(mesh[:-1, None] + s[None, :] * np.diff(mesh)[:, None]).ravel(), mesh[-1:]]))


HINGE_XY = (0.0, 0.0)     # where the pin is (checked by `probe`: A at the origin)


def ref_columns(ref: dict, t: np.ndarray) -> dict:
    """Every state column and multiplier of the library's solution, from the reference at t."""
    e = R.evaluate(ref, t)
    psi, w = e["psi"], e["w"]
    h = R.L / 2
    z = np.zeros_like(t)
    cols = {"rod.x": HINGE_XY[0] + h * np.sin(psi), "rod.y": HINGE_XY[1] - h * np.cos(psi), "rod.z": z,
            "rod.psi": psi, "rod.theta": z, "rod.phi": z, "rod.psi_dot": w, "rod.theta_dot": z, "rod.phi_dot": z,
            "rod.vbar_x": h * w * np.cos(psi), "rod.vbar_y": h * w * np.sin(psi), "rod.vbar_z": z,
            "rod.omega_x": z, "rod.omega_y": z, "rod.omega_z": w,
            "hinge.v1.lambda": e["Fx"], "hinge.v2.lambda": e["Fy"], "hinge.v3.lambda": z,
            "hinge.w1.lambda": z, "hinge.w2.lambda": z, "motor": e["tau"]}
    return cols


STATE_COLS = ["rod.x", "rod.y", "rod.z", "rod.psi", "rod.theta", "rod.phi", "rod.psi_dot", "rod.theta_dot",
              "rod.phi_dot", "rod.vbar_x", "rod.vbar_y", "rod.vbar_z", "rod.omega_x", "rod.omega_y", "rod.omega_z"]
MULT_COLS = ["hinge.v1.lambda", "hinge.v2.lambda", "hinge.v3.lambda", "hinge.w1.lambda", "hinge.w2.lambda"]


def true_errors(sol, ref: dict, load_scale: float, per: int = 16) -> dict:
    """Max |library - reference| at the collocation points and on a dense grid (per points in each final mesh
    interval, through sol.interpolate). States absolute; multipliers / load_scale; motor / largest |tau|."""
    names = set(sol.sample_columns())
    mesh = np.asarray(sol.mesh_refinement["mesh"]) * sol.t_final if sol.mesh_refinement else None
    out = {}
    for where, t in (("points", np.asarray(sol.t)), ("dense", dense_grid(mesh, per) if mesh is not None else None)):
        if t is None:
            continue
        refc = ref_columns(ref, t)
        lib = (lambda n: np.asarray(sol.sample(n))) if where == "points" else (lambda n: sol.interpolate(n, t))
        res = {}
        for group, cols, scale in (("states", STATE_COLS, 1.0), ("multipliers", MULT_COLS, load_scale),
                                   ("inputs", ["motor"], float(np.max(np.abs(refc["motor"]))))):
            worst, arg = -1.0, None
            for n in cols:
                if n not in names:
                    continue
                d = np.abs(lib(n) - refc[n]) / scale
                i = int(np.argmax(d))
                if d[i] > worst:
                    worst, arg = float(d[i]), (n, float(t[i]))
            res[group] = worst
            res[group + "_at"] = arg
        out[where] = res
    return out


def fixed_errors(sol, ref: dict, per: int = 16) -> dict:
    """True errors of a fixed-mesh solution on 4001 evenly spaced times; multipliers relative to the reference's
    largest |lambda| component (19.43 N for W = 1000, at t = 0)."""
    t = np.linspace(0.0, sol.t_final, 4001)
    refc = ref_columns(ref, t)
    # the largest |lambda| component of the reference (the library's load_scale is its largest |lambda|)
    scale = float(max(np.max(np.abs(refc[n])) for n in MULT_COLS))
    names = set(sol.sample_columns())
    st = max(float(np.max(np.abs(sol.interpolate(n, t) - refc[n]))) for n in STATE_COLS if n in names)
    mu_abs = max(float(np.max(np.abs(sol.interpolate(n, t) - refc[n]))) for n in MULT_COLS if n in names)
    return {"states": st, "multipliers": mu_abs / scale, "multipliers_abs": mu_abs, "load_scale_ref": scale}


# ---------------------------------------------------------------------------------------------------- commands
def cmd_probe(name: str) -> None:
    problem = build(name)
    c0 = time.process_time()
    sol = problem.solve(oc.Radau(100, degree=5))
    print(f"Radau(100, 5): {time.process_time() - c0:.1f} s CPU, status {sol.status}, coordinates "
          f"{problem.nlp_coordinates}, J {sol.objective:.10f}")
    ref = load_ref(name)
    print(f"reference J {ref['J']:.10f}")
    xb, yb, psi = (np.asarray(sol.sample(n)) for n in ("rod.x", "rod.y", "rod.psi"))
    ax, ay = xb - (R.L / 2) * np.sin(psi), yb + (R.L / 2) * np.cos(psi)
    print(f"pin A at ({ax.min():.3e}..{ax.max():.3e}, {ay.min():.3e}..{ay.max():.3e})")
    t = np.asarray(sol.t)
    refc = ref_columns(ref, t)
    for n in STATE_COLS + MULT_COLS + ["motor", "hinge.F_x", "hinge.F_y"]:
        if n in sol.sample_columns():
            print(f"  {n:18s} max|lib - ref| {np.max(np.abs(np.asarray(sol.sample(n)) - refc[n])):.2e}")
        elif n in sol.loads():
            k = {"hinge.F_x": "hinge.v1.lambda", "hinge.F_y": "hinge.v2.lambda"}[n]
            print(f"  {n:18s} max|lib - ref| {np.max(np.abs(np.asarray(sol.loads()[n]) - refc[k])):.2e}")


def cmd_one(name: str, tol: float, maxref: int | None, start: str | None = None) -> None:
    problem = build(name)
    method = None
    if start:
        n, d = (int(v) for v in start.split(","))
        method = oc.Radau(n, degree=d)
    c0, w0 = time.process_time(), time.perf_counter()
    err = None
    try:
        sol = problem.solve(method, tolerance=tol, **({"max_refinements": maxref} if maxref else {}))
    except Exception as e:          # recorded, the claim says this never happens
        err = f"{type(e).__name__}: {e}"
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    row = {"problem": name, "tol": tol, "maxref": maxref, "start": start, "cpu": cpu, "wall": wall}
    if err:
        row["exception"] = err[:2000]
        print(json.dumps(row))
        return
    mr = sol.mesh_refinement
    ref = load_ref(name)
    scale = float(mr["history"][-1]["load_scale"])
    mesh = np.asarray(mr["mesh"])
    row.update(met=bool(mr["met"]), intervals=int(mesh.size - 1), points=int(np.asarray(sol.t).size),
               degrees=list(map(int, mr.get("degrees", []))) if mr.get("degrees") is not None else None,
               estimate={k: (None if v is None else float(v)) for k, v in (mr["estimate"] or {}).items()},
               load_scale=scale, message=mr["message"], refinements=len(mr["history"]),
               returned_refinement=mr.get("returned_refinement"), objective=float(sol.objective),
               objective_ref=float(ref["J"]), status=sol.status,
               total_cpu_s=mr.get("total_cpu_s"), total_time_s=mr.get("total_time_s"),
               history=[{k: h.get(k) for k in ("refinement", "intervals", "points", "cpu_s", "companion_cpu_s",
                                               "objective", "estimate", "load_scale", "iterations", "solves",
                                               "resolved", "worst")} for h in mr["history"]],
               switches=mr.get("switches_located"), nonsmooth=mr.get("nonsmooth_intervals"),
               jump_windows=mr.get("jump_windows"))
    row["mesh"] = (mesh * sol.t_final).tolist()
    # the 50 Hz sample times (the reference's kinks / spline knots) strictly inside a final mesh interval
    inner = TK[1:-1]
    gap = np.min(np.abs(inner[:, None] - np.asarray(row["mesh"])[None, :]), axis=1)
    row["samples_inside_intervals"] = int(np.sum(gap > 1e-9))
    row["true"] = true_errors(sol, ref, scale)
    print(json.dumps(row, default=str))


def cmd_fixed(name: str, N: int, deg: int) -> None:
    problem = build(name)
    c0, w0 = time.process_time(), time.perf_counter()
    sol = problem.solve(oc.Radau(N, degree=deg))
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    row = {"problem": name, "N": N, "deg": deg, "cpu": cpu, "wall": wall, "status": sol.status,
           "objective": float(sol.objective), "points": int(np.asarray(sol.t).size)}
    row.update(fixed_errors(sol, load_ref(name)))
    print(json.dumps(row))


def run_capped(args: list[str], cap: float, log: Path) -> dict | None:
    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (int(cap), int(cap) + 5))
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", PYTHONWARNINGS="ignore")
    w0 = time.perf_counter()
    p = subprocess.run([sys.executable, str(HERE / "nc9.py")] + args, capture_output=True, text=True,
                       preexec_fn=limit, env=env, cwd=HERE)
    wall = time.perf_counter() - w0
    with open(log, "a") as f:
        f.write(f"### {' '.join(args)} rc={p.returncode} wall={wall:.1f}\n{p.stderr[-3000:]}\n")
    lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
    if p.returncode != 0 or not lines:
        return {"args": args, "killed": True, "returncode": p.returncode, "wall_outer": wall, "cap": cap,
                "stderr_tail": p.stderr[-500:]}
    row = json.loads(lines[-1])
    row["wall_outer"], row["cap"] = wall, cap
    return row


def cmd_all(name: str, tols: list[float], cap: float, maxref: int | None, start: str | None = None) -> None:
    out = HERE / f"runs_{name}.jsonl"
    for tol in tols:
        args = ["one", name, repr(tol)] + (["--maxref", str(maxref)] if maxref else []) + (
            ["--start", start] if start else [])
        row = run_capped(args, cap, HERE / f"log_{name}.txt")
        row.setdefault("problem", name)
        row.setdefault("tol", tol)
        with open(out, "a") as f:
            f.write(json.dumps(row, default=str) + "\n")
        if row.get("killed"):
            print(f"{name} {tol:g}: KILLED (rc {row['returncode']}, wall {row['wall_outer']:.0f} s)", flush=True)
        elif row.get("exception"):
            print(f"{name} {tol:g}: EXCEPTION {row['exception'][:200]}", flush=True)
        else:
            t, e = row["true"]["dense"], row["estimate"]
            print(f"{name} {tol:g}: met {row['met']} pts {row['points']} int {row['intervals']} cpu {row['cpu']:.1f} "
                  f"est s/m {e['states']:.1e}/{e['multipliers']:.1e} true s/m {t['states']:.1e}/{t['multipliers']:.1e}"
                  f" | {row['message'][:160]}", flush=True)


def cmd_uniform(name: str, deg: int, Ns: list[int], cap: float) -> None:
    out = HERE / f"uniform_{name}.jsonl"
    for N in Ns:
        row = run_capped(["fixed", name, str(N), str(deg)], cap, HERE / f"log_uniform_{name}.txt")
        with open(out, "a") as f:
            f.write(json.dumps(row) + "\n")
        if row.get("killed"):
            print(f"uniform {name} R{deg} N={N}: KILLED", flush=True)
        else:
            print(f"uniform {name} R{deg} N={N}: cpu {row['cpu']:.2f} states {row['states']:.1e} "
                  f"mult {row['multipliers']:.1e} J {row['objective']:.10f}", flush=True)


def main(argv: list[str]) -> None:
    warnings.simplefilter("ignore")
    cap, maxref, start = 120.0, None, None
    if "--start" in argv:
        i = argv.index("--start"); start = argv[i + 1]; del argv[i:i + 2]
    if "--cap" in argv:
        i = argv.index("--cap"); cap = float(argv[i + 1]); del argv[i:i + 2]
    if "--maxref" in argv:
        i = argv.index("--maxref"); maxref = int(argv[i + 1]); del argv[i:i + 2]
    cmd, name = argv[0], argv[1]
    if cmd == "ref":
        cmd_ref(name)
    elif cmd == "probe":
        cmd_probe(name)
    elif cmd == "one":
        cmd_one(name, float(argv[2]), maxref, start)
    elif cmd == "all":
        cmd_all(name, [float(a) for a in argv[2:]] or TOLS, cap, maxref, start)
    elif cmd == "fixed":
        cmd_fixed(name, int(argv[2]), int(argv[3]))
    elif cmd == "uniform":
        deg = int(argv[2]) if len(argv) > 2 else 5
        Ns = [int(a) for a in argv[3:]] or [10, 20, 40, 50, 80, 100, 160, 200, 320, 400]
        cmd_uniform(name, deg, Ns, cap)
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
