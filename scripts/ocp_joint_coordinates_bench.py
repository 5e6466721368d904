"""Pendulum swing-up, Radau 3: ours in maximal coordinates, ours in joint coordinates, rockit.

    python scripts/ocp_joint_coordinates_bench.py [--N 25 50 100 200 400] [--runs 3] [--degree 3]
    python scripts/ocp_joint_coordinates_bench.py --degree 9 --N 20 --runs 3     # high accuracy
    python scripts/ocp_joint_coordinates_bench.py --N 25 50 100 200 400 800 1600 --solvers joint rockit
                                                      # how the time grows with N (fitted exponent)

One interleaved run: for each repetition, each N, each solver in turn (so a noisy neighbour
hits all three alike). Per solver and N, the medians over the runs of:
- ``solve``: IPOPT's own time from CasADi's solver stats (``t_wall_total``, ``t_proc_total``):
  the NLP solve with every function evaluation and factorization, the same measure for all three;
- ``build``: everything from the problem to the solution but IPOPT (ours: task, transcription,
  ``nlpsol``, start, solution in the bodies' coordinates; rockit: its ``Ocp``, ``DirectCollocation``
  and the transcription and set-up it does in ``solve()``), wall time; and problem to solution
  in all, wall and CPU (``time.process_time``);
- iterations, ms per iteration (IPOPT wall / iterations), the objective and its error against the
  Pontryagin extremal (bench/references.py, shooting on the 1-DOF equation: an independent value);
- NLP size (variables, constraints); ours: the largest state error and hinge-multiplier error
  (relative to the largest hinge load, t > 0) against the extremal's hand Newton-Euler loads.
rockit's swing-up is bench/peers.py's ``rockit_swing_up`` (minimal coordinates psi, psi', one
piecewise-constant control per interval), here with the solver stats read out.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

import ocp_constraints as oc
from ocp_constraints.bench.peers import rockit_swing_up
from ocp_constraints.bench.references import swing_up_reference


def _errors(sol, ref) -> tuple[float, float]:
    """Largest state error (rad, rad/s) and hinge-multiplier error relative to the largest hinge load
    (25.15 N), t > 0 (Radau has no defect of its own at t = 0), against the Pontryagin extremal."""
    psi, w = ref.states(sol.t)
    state = max(np.abs(sol.sample("rod.psi") - psi).max(), np.abs(sol.sample("rod.psi_dot") - w).max())
    lam = ref.multipliers(sol.t)
    return float(state), max(float(np.abs(sol.sample(k)[1:] - lam[k][1:]).max()) for k in ("hinge.v1.lambda",
                                                                                        "hinge.v2.lambda")) / 25.15


def ours(N: int, degree: int, coordinates: str, ref=None) -> dict:
    started, cpu = time.perf_counter(), time.process_time()
    _, ocp = oc.build_task("pendulum", "swing_up")
    ocp.coordinates = coordinates
    tr = ocp.transcription(oc.Radau(N, degree=degree))
    sol = tr.solve({"record_time": True})
    total, total_cpu = time.perf_counter() - started, time.process_time() - cpu
    st = sol.stats
    state, lam = _errors(sol, ref) if ref is not None else (np.nan, np.nan)
    return {"objective": sol.objective, "iterations": sol.iterations, "solve_wall": st["t_wall_total"],
            "state_error": state, "lambda_error": lam,
            "solve_cpu": st["t_proc_total"], "build": total - st["t_wall_total"], "total": total, "total_cpu": total_cpu,
            "size": (tr.nlp["x"].numel(), tr.nlp["g"].numel())}


def rockit(N: int, degree: int) -> dict:
    r = rockit_swing_up(N, degree)
    return {"objective": r["objective"], "iterations": r["iterations"], "solve_wall": r["ipopt_wall_s"],
            "solve_cpu": r["ipopt_cpu_s"], "build": r["total_s"] - r["ipopt_wall_s"], "total": r["total_s"],
            "total_cpu": r["total_cpu_s"], "state_error": np.nan, "lambda_error": np.nan, "size": r["size"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--N", type=int, nargs="+", default=[25, 50, 100, 200, 400])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--degree", type=int, default=3)
    ap.add_argument("--solvers", nargs="+", choices=["maximal", "joint", "rockit"], default=["maximal", "joint", "rockit"])
    args = ap.parse_args()
    reference = swing_up_reference()
    ref = reference.objective
    solvers = {"maximal": lambda N: ours(N, args.degree, "maximal", reference),
               "joint": lambda N: ours(N, args.degree, "joint", reference),
               "rockit": lambda N: rockit(N, args.degree)}
    solvers = {k: f for k, f in solvers.items() if k in args.solvers or k == "rockit"}   # rockit: the ratios' base
    for name, f in solvers.items():       # warm-up: imports, CasADi's first JIT-free set-up
        f(args.N[0])
    rows: dict = {}
    cpu0 = time.process_time()
    for _ in range(args.runs):
        for N in args.N:
            for name, f in solvers.items():
                rows.setdefault((name, N), []).append(f(N))
    print(f"Pendulum swing-up, Radau {args.degree}, medians of {args.runs} interleaved runs "
          f"(Pontryagin objective {ref:.9f}); bench CPU {time.process_time() - cpu0:.1f} s")
    print("| N | solver | NLP vars x cons | iterations | IPOPT wall (s) | IPOPT CPU (s) | ms/iteration | build wall (s) "
          "| problem to solution wall / CPU (s) | objective | objective error | IPOPT wall / rockit's | IPOPT CPU / rockit's "
          "| problem to solution CPU / rockit's | state error | lambda error (relative, t > 0) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for N in args.N:
        rock = {k: np.median([r[k] for r in rows[("rockit", N)]]) for k in ("solve_wall", "solve_cpu", "total_cpu")}
        for name in solvers:
            rs = rows[(name, N)]
            med = {k: float(np.median([r[k] for r in rs])) for k in ("iterations", "solve_wall", "solve_cpu", "build",
                                                                      "total", "total_cpu", "objective")}
            nx, ng = rs[0]["size"]
            print(f"| {N} | {name} | {nx} x {ng} | {med['iterations']:.0f} | {med['solve_wall']:.4f} | "
                  f"{med['solve_cpu']:.4f} | {1e3 * med['solve_wall'] / max(med['iterations'], 1):.2f} | "
                  f"{med['build']:.3f} | {med['total']:.3f} / {med['total_cpu']:.3f} | {med['objective']:.9f} | "
                  f"{abs(med['objective'] - ref):.1e} | {med['solve_wall'] / rock['solve_wall']:.2f} | "
                  f"{med['solve_cpu'] / rock['solve_cpu']:.2f} | {med['total_cpu'] / rock['total_cpu']:.2f} | "
                  f"{rs[0]['state_error']:.1e} | {rs[0]['lambda_error']:.1e} |")
    if len(args.N) > 2:
        # Solve time ~ N^k: least-squares slope of log(median time) on log(N), IPOPT's and problem to solution.
        logN = np.log(args.N)
        for name in solvers:
            for key in ("solve_cpu", "total_cpu"):
                y = np.log([np.median([r[key] for r in rows[(name, N)]]) for N in args.N])
                print(f"{name}: {key} ~ N^{np.polyfit(logN, y, 1)[0]:.2f} (N = {args.N[0]}..{args.N[-1]})")


if __name__ == "__main__":
    main()
