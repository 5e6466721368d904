"""Every optimal-control problem we have, solved from its default guess, in the default coordinates
("auto") and in maximal coordinates, on one or two meshes: does a user's own OCP stall, land in a
poor optimum or run slowly from where the library starts it?

    python scripts/ocp_default_robustness.py [--runs 3] [--only NAME ...] [--meshes R3N20 R7N5]
        [--candidate NAME ...] [--jobs 1] [--json PATH] [--markdown results/bench/ocp_default_robustness.md]

The problems (none written or tuned for this table): the scene tasks (``ocp-constraints list``), the
six suite problems (``bench/ocp_suite_run.PROBLEMS``, our side), the seven newcomer problems
(``scripts/newcomer_problems.py``), the examples' OCPs (``examples/*.py``, built as each script builds
it) and the free-floating satellite of ``tests/test_ocp_quaternions.py``. Each run builds the problem
from an empty model and solves it (``time.process_time`` and wall time of both); per run: IPOPT's
status, iterations, objective; CPU and wall: medians over ``--runs``. Where "auto" picks maximal
coordinates the two columns are one NLP and it is solved once. ``--jobs N`` runs the rows on an embedded
Dask ``LocalCluster`` of N single-threaded worker processes (``client.map``/``gather``; the ``batch`` extra).

A candidate (``--candidate``, see :data:`CANDIDATES`) is a change of the IPOPT options or of the
joint-coordinate start, run on the same table; each is compared row by row with ``default``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
ROOT = Path(__file__).resolve().parent.parent

MESHES = {"R3N20": (3, 20), "R7N5": (7, 5), "R3N10": (3, 10), "R7N20": (7, 20)}


def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module          # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


# -- the problems: name -> builder() returning the problem with its own (default) coordinates ----------
def _scene(scene: str, task: str):
    def build():
        from ocp_constraints.scenes.registry import build_task

        return build_task(scene, task)[1]
    return build


def _suite(name: str):
    def build():
        from ocp_constraints.bench.ocp_suite_run import PROBLEMS

        return next(sp for sp in PROBLEMS if sp.name == name).ours(coordinates="auto")
    return build


def _newcomer(name: str):
    def build():
        module = _load(ROOT / "scripts" / "newcomer_problems.py", "newcomer_problems")
        return module.PROBLEMS[name][0]()
    return build


def _example(file: str):
    """The script's own code up to its first ``ocp.solve`` (or its ``if __name__ == "__main__":`` block, where it
    solves there): the problem exactly as the example writes it."""
    def build():
        lines = (ROOT / "examples" / file).read_text().splitlines()
        stop = next(i for i, line in enumerate(lines) if ".solve(" in line or line.startswith("if __name__"))
        namespace = {"__name__": "example_" + file[:-3]}
        exec(compile("\n".join(lines[:stop]), str(ROOT / "examples" / file), "exec"), namespace)
        return namespace["ocp"]
    return build


def _robot_arm():
    """examples/robot_arm_urdf.py's first problem (UR5, minimum effort, limits, no reaction bound)."""
    import numpy as np

    import ocp_constraints as oc

    module = _load(ROOT / "examples" / "robot_arm_urdf.py", "robot_arm_urdf")
    robot = oc.load_urdf(module.default_urdf(), base="ground")
    qa, qb = np.array([0.0, -1.2, 1.4, -0.2, 0.0, 0.0]), np.array([0.8, -0.4, 0.6, -0.2, 0.0, 0.0])
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
    robot.set_boundary(problem, "initial", qa)
    robot.set_boundary(problem, "final", qb)
    robot.set_guess(problem, lambda s: qa + (qb - qa) * (3 * np.clip(s, 0, 1) ** 2 - 2 * np.clip(s, 0, 1) ** 3)[:, None])
    robot.apply_limits(problem)
    problem.minimize_effort()
    return problem


def _satellite():
    return _load(ROOT / "tests" / "test_ocp_quaternions.py", "test_ocp_quaternions")._satellite("auto")


PROBLEMS = {
    "scene:pendulum.swing_up": _scene("pendulum", "swing_up"),
    "scene:rolling_disk.drive": _scene("rolling_disk", "drive"),
    "scene:whirling.spin_up": _scene("whirling", "spin_up"),
    "scene:ball_socket.reach": _scene("ball_socket", "reach"),
    **{f"suite:{n}": _suite(n) for n in ("acrobot", "cart_double_pendulum", "four_bar", "rolling_disk",
                                         "quadrotor_load", "walker")},
    **{f"newcomer:{n}": _newcomer(n) for n in ("arm", "slider_crank", "spherical", "cart_pole", "wheel",
                                              "arm_free_time", "crane")},
    "example:cart_pole_by_hand": _example("cart_pole_by_hand.py"),
    "example:spherical_pendulum": _example("spherical_pendulum.py"),
    "example:swing_up": _example("swing_up.py"),
    "example:wheel_on_slope": _example("wheel_on_slope.py"),
    "example:robot_arm_urdf": _robot_arm,
    "test:satellite": _satellite,
}


# -- candidates: IPOPT options and/or a joint-coordinate speed start ---------------------------------
CANDIDATES = {
    "default": {},
    "alpha_for_y=min-dual-infeas": {"ipopt": {"ipopt.alpha_for_y": "min-dual-infeas"}},
    "mu_strategy=adaptive": {"ipopt": {"ipopt.mu_strategy": "adaptive"}},
    "mu_init=1e-2": {"ipopt": {"ipopt.mu_init": 1e-2}},
    "constr_mult_init_max=0": {"ipopt": {"ipopt.constr_mult_init_max": 0.0}},
    "bound_push=1e-4": {"ipopt": {"ipopt.bound_push": 1e-4, "ipopt.bound_frac": 1e-4}},
    "nlp_scaling=none": {"ipopt": {"ipopt.nlp_scaling_method": "none"}},
    "watchdog_trigger=3": {"ipopt": {"ipopt.watchdog_shortened_iter_trigger": 3}},
    "speeds=rates": {"speeds": "rates"},
    "speeds=rates+alpha_for_y": {"speeds": "rates", "ipopt": {"ipopt.alpha_for_y": "min-dual-infeas"}},
    "smoothstep+rates": {"speeds": "rates", "coordinates": "smoothstep"},
    "speeds=rest-to-rest rates": {"speeds": "smooth"},
    "obj_scaling=1e2": {"ipopt": {"ipopt.obj_scaling_factor": 1e2}},
    "obj_scaling=1e3": {"ipopt": {"ipopt.obj_scaling_factor": 1e3}},
    "obj_scaling=1e4": {"ipopt": {"ipopt.obj_scaling_factor": 1e4}},
    # The refinement's warm-solve rule (ocp/objective_scaling.py) applied to the cold solve: 1 / the objective's
    # largest curvature at the problem's own guess.
    "obj_scaling=curvature": {"objective_scale": True},
    # MUMPS's fill-reducing ordering (IPOPT's default 7 lets MUMPS choose; on the walker in maximal coordinates it chose an
    # ordering whose factorizations took 0.3 s each on 7,370 variables, against 0.1 s with QAMD or AMD).
    "mumps_pivot_order=0": {"ipopt": {"ipopt.mumps_pivot_order": 0}},
    "mumps_pivot_order=6": {"ipopt": {"ipopt.mumps_pivot_order": 6}},
}


def _smoothstep_guesses(problem) -> None:
    """Candidate 'smoothstep+rates': a coordinate with both boundary values and no guess is guessed
    ``a + (b - a) (3 s^2 - 2 s^3)`` (s = t / T) instead of linear, so its rate vanishes at both ends as a
    rest-to-rest motion's does; set as a user would, with ``set_guess``."""
    T = problem.t_final
    for n in problem.model.coordinate_names:
        if n in problem.initial_values and n in problem.final_values and n not in problem.guess:
            a, b = problem.initial_values[n], problem.final_values[n]
            problem.set_guess(n, lambda t, a=a, b=b: a + (b - a) * (3 * (t / T) ** 2 - 2 * (t / T) ** 3))


def _use_rate_speeds(smooth: bool = False) -> None:
    """Candidate 'speeds=rates': in joint coordinates the start's speeds are the guessed joint
    coordinates' time derivative for trees too (as the library does for loops), not the boundary
    speeds projected. Patched here so the library's files stay as they are while it is measured."""
    import casadi as ca
    import numpy as np

    from ocp_constraints.ocp import joint_transcription as jt

    original = _ORIGINAL.setdefault("speeds", jt.JointGuess.speeds)

    def speeds(self, p, targets, t, W):
        if p.shape[1] < 2:
            return original(self, p, targets, t, W)
        P, nu, nc = p.shape[1], self.r.nu, self.r.nc
        # p' = N(p) u_r (a quaternion has four rates for three speeds): u_r by least squares at each point.
        if "_rates" not in self.__dict__:
            self._rates = ca.Function("N", [self.r.q], [ca.jacobian(self.r.qdot, self.r.u)]).map(P)
        N = np.asarray(self._rates(p)).reshape(-1, P, nu).transpose(1, 0, 2)
        dp = np.gradient(p, t, axis=1)
        if smooth:      # the same path at a rest-to-rest pace: rates times 6 s (1 - s), zero at both ends
            s = (t - t[0]) / (t[-1] - t[0])
            dp = dp * 6 * s * (1 - s)
        rates = (np.linalg.pinv(N) @ dp.T[:, :, None])[:, :, 0].T
        if nc == 0:
            return rates
        # Remaining velocity constraints (a contact, a hand-written row): the rates moved onto them.
        Mr, _, G, e = (np.asarray(v) for v in self._functions["metric"].map(P)(p, t[None, :], W))
        Mr = Mr.reshape(nu, P, nu).transpose(1, 0, 2)
        G = G.reshape(nc, P, nu).transpose(1, 0, 2)
        K = np.block([[Mr, np.transpose(G, (0, 2, 1))], [G, np.zeros((P, nc, nc))]])
        b = np.concatenate([np.einsum("pij,jp->pi", Mr, rates), -e.reshape(nc, P).T], axis=1)
        return (np.linalg.pinv(K) @ b[:, :, None])[:, :nu, 0].T

    jt.JointGuess.speeds = speeds


_ORIGINAL: dict = {}


def _speeds_patch(candidate: str) -> None:
    """The candidate's joint-coordinate speed start, or the library's own (a process may run several candidates)."""
    if CANDIDATES[candidate].get("speeds") in ("rates", "smooth"):
        _use_rate_speeds(smooth=CANDIDATES[candidate]["speeds"] == "smooth")
    elif "speeds" in _ORIGINAL:
        from ocp_constraints.ocp import joint_transcription as jt

        jt.JointGuess.speeds = _ORIGINAL["speeds"]


def run_once(name: str, mesh: str, coordinates: str, candidate: str) -> dict:
    """Build ``name`` from an empty model and solve it; status, iterations, objective, CPU and wall."""
    import ocp_constraints as oc

    degree, N = MESHES[mesh]
    options = {"ipopt.max_cpu_time": 300.0, **CANDIDATES[candidate].get("ipopt", {})}
    cpu, wall = time.process_time(), time.perf_counter()
    row = {"problem": name, "mesh": mesh, "coordinates": coordinates, "candidate": candidate}
    try:
        problem = PROBLEMS[name]()
        problem.coordinates = coordinates
        if CANDIDATES[candidate].get("coordinates") == "smoothstep":
            _smoothstep_guesses(problem)
        row["nlp"] = problem.nlp_coordinates
        if CANDIDATES[candidate].get("objective_scale"):
            from ocp_constraints.ocp.objective_scaling import OPTION, objective_scale

            tr = problem.transcription(oc.Radau(N, degree=degree))
            options[OPTION] = row["objective_scale"] = objective_scale(tr.block, tr.initial_guess())
        sol = problem.solve(oc.Radau(N, degree=degree), options, progress=False)
        row.update(success=bool(sol.success), status=sol.status, iterations=int(sol.iterations),
                   objective=float(sol.objective))
    except oc.OCPSolveError as exc:
        s = exc.solution
        row.update(success=False, status=str(getattr(s, "status", exc))[:80],
                   iterations=int(getattr(s, "iterations", -1) or -1), objective=float(getattr(s, "objective", math.nan)))
    except Exception as exc:        # a problem we cannot even build: reported, never hidden
        row.update(success=False, status=f"{type(exc).__name__}: {exc}"[:120], iterations=-1, objective=math.nan)
    row.update(cpu=time.process_time() - cpu, wall=time.perf_counter() - wall)
    return row


def continued(name: str, mesh: str, candidate: str, fine: list[int]) -> str:
    """Which optimum a coarse solve found: its solution warm-started onto Radau 7 with each N of ``fine`` in
    turn, in the default coordinates (a coarse objective alone may be a discretization artifact)."""
    import ocp_constraints as oc

    _speeds_patch(candidate)
    degree, N = MESHES[mesh]
    problem = PROBLEMS[name]()
    if CANDIDATES[candidate].get("coordinates") == "smoothstep":
        _smoothstep_guesses(problem)
    options = CANDIDATES[candidate].get("ipopt", {})
    sol = problem.solve(oc.Radau(N, degree=degree), options, progress=False)
    out = [f"{sol.objective:.8g}"]
    for n in fine:
        try:
            sol = problem.solve(oc.Radau(n, degree=7), options, warm_start=sol, progress=False)
            out.append(f"R7N{n} {sol.objective:.8g} ({sol.iterations} it)")
        except oc.OCPSolveError as exc:
            out.append(f"R7N{n} failed: {exc.solution.status}")
            break
    return f"{candidate} {name} {mesh}: " + " -> ".join(out)


def _task(args: tuple) -> dict:
    name, mesh, coordinates, candidate, runs = args
    _speeds_patch(candidate)
    rows = [run_once(name, mesh, coordinates, candidate) for _ in range(runs)]
    out = dict(rows[0])
    out["cpu"] = statistics.median(r["cpu"] for r in rows)
    out["wall"] = statistics.median(r["wall"] for r in rows)
    out["runs"] = runs
    return out


def _task_in_worker(args: tuple) -> dict:
    """``_task`` in a Dask worker: this script loaded there by path (a worker has no ``__main__`` of ours),
    so its patches (``_speeds_patch``) act on the worker's own imports."""
    return _load(ROOT / "scripts" / "ocp_default_robustness.py", "ocp_default_robustness")._task(args)


def _auto_is_maximal(name: str) -> bool:
    return PROBLEMS[name]().nlp_coordinates == "maximal"


def measure(names, meshes, candidates, runs, jobs) -> list[dict]:
    tasks = []
    maximal_only = {n: _auto_is_maximal(n) for n in names}
    for cand in candidates:
        # A change of the joint-coordinate start alone leaves every maximal NLP as it is: not run again.
        joint_only = "ipopt" not in CANDIDATES[cand] and cand != "default"
        for n in names:
            for m in meshes:
                forms = ("maximal",) if maximal_only[n] else ("auto", "maximal")
                for c in forms:
                    if not (joint_only and (maximal_only[n] or c == "maximal")):
                        tasks.append((n, m, c, cand, runs))
    rows = []
    if jobs > 1:
        # Scale-out goes through Dask (as ocp_constraints.batch does): an embedded LocalCluster of ``jobs``
        # single-threaded worker processes; rows come back in the tasks' order, as the serial loop gives them.
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=":0",
                          host="127.0.0.1") as cluster, Client(cluster) as client:
            for row in client.gather(client.map(_task_in_worker, tasks, pure=False)):
                _echo(row)
                rows.append(row)
    else:
        for t in tasks:
            row = _task(t)
            _echo(row)
            rows.append(row)
    for r in list(rows):      # where auto is maximal, the default column is the maximal one
        if maximal_only[r["problem"]]:
            rows.append({**r, "coordinates": "auto"})
    return rows


def _echo(r: dict) -> None:
    print(f"{r['candidate']:28s} {r['problem']:32s} {r['mesh']:6s} {r['coordinates']:8s} "
          f"{'ok ' if r['success'] else 'FAIL'} {r['iterations']:5d} it  J {r['objective']:.8g}  "
          f"{r['cpu']:.2f} s CPU  {r['wall']:.2f} s wall  {'' if r['success'] else r['status']}", flush=True)


def table(rows: list[dict], candidate: str = "default") -> str:
    """Markdown: one row per problem and mesh, the default ('auto') and the maximal form side by side."""
    by = {(r["problem"], r["mesh"], r["coordinates"]): r for r in rows if r["candidate"] == candidate}
    keys = sorted({(p, m) for p, m, _ in by}, key=lambda k: (list(PROBLEMS).index(k[0]), k[1]))
    out = [f"| problem | mesh | default: NLP form | default: status, iterations | default: J | default: CPU s (wall s) "
           f"| maximal: status, iterations | maximal: J | maximal: CPU s (wall s) |", "|---|" * 1 + "---|" * 8]
    for p, m in keys:
        a, x = by.get((p, m, "auto")), by.get((p, m, "maximal"))
        cells = [p, m]
        for r, show_form in ((a, True), (x, False)):
            if r is None:
                cells += [""] * (4 if show_form else 3)
                continue
            if show_form:
                cells.append(r.get("nlp", "?"))
            ok = "yes" if r["success"] else f"**no** ({r['status']})"
            cells += [f"{ok}, {r['iterations']}", f"{r['objective']:.8g}", f"{r['cpu']:.2f} ({r['wall']:.2f})"]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def comparison(rows: list[dict], candidates: list[str]) -> str:
    """Each candidate against 'default', summed over the table: iterations, CPU, failures, and the rows
    where it solved worse (failed where the default solved, or a higher objective by > 1e-6 relative)."""
    base = {(r["problem"], r["mesh"], r["coordinates"]): r for r in rows if r["candidate"] == "default"}
    out = ["| candidate | rows solved | total iterations (the default's on the same rows) | total CPU s (the default's) | "
           "rows with fewer / more iterations | "
           "worse rows (failed where the default solved, or objective > default's by > 1e-6 rel.) | better objective rows |",
           "|---|---|---|---|---|---|---|"]
    for cand in candidates:
        mine = {(r["problem"], r["mesh"], r["coordinates"]): r for r in rows if r["candidate"] == cand}
        # An 'auto' row that is the maximal NLP is counted once, as its maximal row.
        keys = [k for k in mine if k in base and not (k[2] == "auto" and base[k].get("nlp") == "maximal")]
        solved = sum(mine[k]["success"] for k in keys)
        its = f"{sum(max(mine[k]['iterations'], 0) for k in keys)} ({sum(max(base[k]['iterations'], 0) for k in keys)})"
        cpu = f"{sum(mine[k]['cpu'] for k in keys):.1f} ({sum(base[k]['cpu'] for k in keys):.1f})"
        fewer = sum(mine[k]["iterations"] < base[k]["iterations"] for k in keys)
        more = sum(mine[k]["iterations"] > base[k]["iterations"] for k in keys)
        worse, better = [], []
        for k in keys:
            b, c = base[k], mine[k]
            if b["success"] and not c["success"]:
                worse.append(f"{k[0]} {k[1]} {k[2]}: failed ({c['status']})")
            elif b["success"] and c["objective"] > b["objective"] + 1e-6 * max(1.0, abs(b["objective"])):
                worse.append(f"{k[0]} {k[1]} {k[2]}: J {c['objective']:.6g} vs {b['objective']:.6g}")
            elif c["success"] and (not b["success"] or c["objective"] < b["objective"] - 1e-6 * max(1.0, abs(b["objective"]))):
                better.append(f"{k[0]} {k[1]} {k[2]}: J {c['objective']:.6g} vs {b['objective']:.6g}"
                              + ("" if b["success"] else " (default failed)"))
        out.append(f"| {cand} | {solved}/{len(keys)} | {its} | {cpu} | {fewer} / {more} | "
                   f"{'; '.join(worse) or 'none'} | {'; '.join(better) or 'none'} |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="builds and solves per row (CPU and wall: medians)")
    ap.add_argument("--only", nargs="*", default=None, help=f"problems (default: all): {', '.join(PROBLEMS)}")
    ap.add_argument("--meshes", nargs="*", default=["R3N20", "R7N5"], choices=list(MESHES))
    ap.add_argument("--candidate", nargs="*", default=["default"], choices=list(CANDIDATES))
    ap.add_argument("--jobs", type=int, default=1,
                    help="Dask worker processes of an embedded LocalCluster (CPU time is per process; wall is inflated)")
    ap.add_argument("--json", type=Path, default=None, help="also write the rows as JSON (and read earlier ones)")
    ap.add_argument("--markdown", type=Path, default=None, help="write the tables to this file")
    ap.add_argument("--tables-only", action="store_true", help="run nothing: the tables of the rows in --json")
    ap.add_argument("--continue-to", nargs="*", type=int, default=None, metavar="N",
                    help="instead of the table: each --only problem's coarse solution (each --meshes, each --candidate) "
                         "warm-started onto Radau 7 with these N in turn, to see which optimum it is")
    args = ap.parse_args()
    names = args.only or list(PROBLEMS)
    unknown = sorted(set(names) - set(PROBLEMS))
    if unknown:
        ap.error(f"unknown problem(s) {unknown}; known: {', '.join(PROBLEMS)}")
    started = time.perf_counter()
    if args.continue_to:
        for cand in args.candidate:
            for n in names:
                for m in args.meshes:
                    print(continued(n, m, cand, args.continue_to), flush=True)
        return
    rows = [] if args.tables_only else measure(names, args.meshes, args.candidate, args.runs, args.jobs)
    if args.json is not None:
        earlier = json.loads(args.json.read_text()) if args.json.exists() else []
        fresh = {(r["problem"], r["mesh"], r["coordinates"], r["candidate"]) for r in rows}
        rows = [r for r in earlier if (r["problem"], r["mesh"], r["coordinates"], r["candidate"]) not in fresh] + rows
        args.json.write_text(json.dumps(rows, indent=1))
    candidates = [c for c in CANDIDATES if any(r["candidate"] == c for r in rows)]
    text = [table(rows)]
    if len(candidates) > 1:
        text += ["", comparison(rows, candidates)]
    print("\n" + "\n".join(text))
    print(f"\n{time.perf_counter() - started:.0f} s wall", file=sys.stderr)
    if args.markdown is not None:
        import platform

        import casadi

        head = (f"# OCPs from their default guess: default ('auto') and maximal coordinates\n\n"
                f"Written by `python scripts/ocp_default_robustness.py {' '.join(sys.argv[1:])}` "
                f"({time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, Python {platform.python_version()}, "
                f"CasADi {casadi.__version__}, load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores). "
                f"CPU: time.process_time of build + solve, median of {args.runs}; wall in brackets.\n\n")
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(head + "\n".join(text) + "\n")


if __name__ == "__main__":
    main()
