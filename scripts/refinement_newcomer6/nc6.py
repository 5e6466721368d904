"""Newcomer check 6: solve(tolerance=TOL) of four problems (models.py) against the references of ref.py.

    python nc6.py run PROBLEM TOL        # one refined solve; its record as JSON on the last line
    python nc6.py all [PROBLEM ...]      # every tolerance, one subprocess at a time (CPU cap 120 s, wall 300 s),
                                         # appended to results.jsonl
PROBLEM: a name of models.VARIANTS (fourbar, fourbar_max, fourbar_turn, fourbar_toggle, sph, sph_big, sleigh,
sleigh_turn, track, track_steep), optionally with "@rDnN": refined from the mesh Radau D x N
(solve(oc.Radau(N, degree=D), tolerance=TOL)) instead of the default start (Radau 5 x 10).

True errors: the library's polynomials (sol.interpolate) against the reference's interval polynomials (ref.evaluate)
on a dense grid, 16 (env DENSE) points inside every interval of the library's final mesh, either side of every
junction (the reference's and the library's located ones), plus the library's own points (sol.t;
multipliers without t = 0); env REF: compare with ref_REF.npz instead of ref_PROBLEM.npz. States: every body coordinate and speed the reference has (for the ball-and-socket rod
the centre's position and velocity, the fixed-basis angular velocity and the quaternion), plus the body coordinates
that stay 0 in a planar motion; multipliers: every multiplier channel (those that vanish included), relative to the
library's own load scale history[-1]["load_scale"]. "at_points": the same at sol.t only.
"""
import json, os, resource, subprocess, sys, time
import numpy as np

# The folder of the check: its models.py, ref.py, ref_*.npz and results.jsonl (a later check runs this harness on
# its own folder: scripts/refinement_newcomer7/nc7.py sets NEWCOMER_DIR).
HERE = os.environ.get("NEWCOMER_DIR") or os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
TOLS = ["1e-3", "1e-4", "1e-5", "1e-6"]
CPU_CAP, WALL_CAP = 120, 300


def load_ref(problem):
    return np.load(os.path.join(HERE, f"ref_{os.environ.get('REF', problem)}.npz"), allow_pickle=True)["ref"].item()


def errors(sol, ref, frac_grid):
    from ref import evaluate
    T = float(sol.t_final)
    t = frac_grid * T
    out = {"states": 0.0, "multipliers": 0.0, "where": {}, "per_state": {}, "per_load": {}}
    for n in list(ref["states"]) + list(ref["zero_states"]):
        rv = evaluate(ref, n, frac_grid, "state") if n in ref["states"] else 0.0
        d = np.asarray(sol.interpolate(n, t), float) - rv
        if n in ref["angles"]:
            d = (d + np.pi) % (2 * np.pi) - np.pi
        k = int(np.argmax(np.abs(d)))
        out["per_state"][n] = float(abs(d[k]))
        if abs(d[k]) > out["states"]:
            out["states"] = float(abs(d[k])); out["where"]["states"] = (float(t[k]), n)
    # the last history entry with a load scale (a failed last solve's entry has none; none at all where the first
    # mesh's companion failed and nothing was estimated: then the reference's largest load on the grid)
    m = frac_grid > 0
    scale = next((float(h["load_scale"]) for h in reversed(sol.mesh_refinement["history"]) if "load_scale" in h), None)
    if scale is None:
        scale = max(float(np.abs(evaluate(ref, n, frac_grid[m], "load")).max()) for n in ref["loads"])
    for n in list(ref["loads"]) + list(ref["zeros"]):
        lv = np.asarray(sol.interpolate(n + ".lambda", t[m]), float)
        rv = evaluate(ref, n, frac_grid[m], "load") if n in ref["loads"] else 0.0
        d = np.abs(lv - rv) / scale
        k = int(np.argmax(d))
        out["per_load"][n] = float(d[k])
        if d[k] > out["multipliers"]:
            out["multipliers"] = float(d[k]); out["where"]["multipliers"] = (float(t[m][k]), n)
    out["load_scale"] = scale
    return out


def dense_grid(sol, per=16):
    mesh = np.asarray(sol.mesh_refinement["mesh"], float)
    inner = (mesh[:-1, None] + np.diff(mesh)[:, None] * ((np.arange(per) + 0.5) / per)[None, :]).ravel()
    pts = np.asarray(sol.t, float) / float(sol.t_final)
    return np.unique(np.concatenate([inner, pts])), pts


def cmd_run(problem, tol):
    import models as M
    import ocp_constraints as oc
    name, _, start = problem.partition("@")     # "track_steep@r3n40": refined from the mesh Radau 3 x 40
    method = None
    if start:
        d, n_ = start[1:].split("n")
        method = oc.Radau(int(n_), degree=int(d))
    pr = M.build(name)
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        sol = pr.solve(method, tolerance=float(tol))
    except Exception as exc:  # noqa: BLE001 - a crash is a finding
        print(json.dumps({"problem": problem, "tol": tol, "crash": f"{type(exc).__name__}: {str(exc)[:800]}",
                          "cpu": time.process_time() - c0}))
        return
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    mr = sol.mesh_refinement
    ref = load_ref(name)
    grid, pts = dense_grid(sol, int(os.environ.get("DENSE", 16)))
    # and either side of every junction (the reference's, and the library's located ones): a kink's peak error
    js = [j for j in ref.get("junctions", [])] + [s["fraction"] for s in (mr.get("switches_located") or []) if "fraction" in s]
    grid = np.unique(np.concatenate([grid] + [np.array([j - 1e-10, j + 1e-10]) for j in js]))
    grid = grid[(grid >= 0) & (grid <= 1)]
    e = errors(sol, ref, grid)
    ep = errors(sol, ref, pts)
    est = {k: (float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v)
           for k, v in (mr.get("estimate") or {}).items()}
    mesh = np.asarray(mr["mesh"], float)
    hist = mr.get("history", [])
    rec = {"problem": problem, "tol": tol, "met": bool(mr.get("met")), "message": str(mr.get("message")),
           "cpu": cpu, "wall": wall, "points": int(sol.transcription.scheme.point_count), "status": sol.status,
           "intervals": len(mesh) - 1, "degrees": mr.get("degrees"), "solves": len(hist),
           "meshes": [h.get("points", h.get("mesh_points")) for h in hist],
           "estimate": est, "true": e, "true_at_points": {k: ep[k] for k in ("states", "multipliers", "where")},
           "ratio": {k: (e[k] / est[k] if isinstance(est.get(k), float) and est[k] > 0 else None)
                     for k in ("states", "multipliers")},
           "objective": float(sol.objective), "objective_ref": ref["objective"],
           "ref_accuracy": ref["accuracy"], "coordinates": mr.get("coordinates"),
           "switches_located": mr.get("switches_located"), "nonsmooth_intervals": mr.get("nonsmooth_intervals"),
           "bounds_passed_between_points": mr.get("bounds_passed_between_points"),
           "min_interval": float(np.diff(mesh).min()) * float(sol.t_final)}
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
            print(json.dumps(short, default=str)[:600], flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "run":
        cmd_run(sys.argv[2], sys.argv[3])
    elif sys.argv[1] == "all":
        import models
        cmd_all(sys.argv[2:] or getattr(models, "DEFAULT", ["fourbar", "sph", "sleigh", "track"]))
