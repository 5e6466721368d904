"""Speed of the knee's direct collocation (``knee --method collocation``) and whether its solution is unchanged.

    python scripts/knee_collocation_speed.py [--trial ngait_og5] [--data DIR] [--runs 1]
        [--save-before results/knee/collocation_speed/before_<trial>.npz]

Builds the collocation's inputs exactly as the ``knee`` command does (:func:`run_knee` with the default model and
settings, C13), then times :func:`solve_collocation` alone: CPU (``time.process_time``) and wall seconds, IPOPT
iterations and IPOPT's own time split (``t_proc_*`` / ``t_wall_*`` of ``solver.stats()``, captured by wrapping
``casadi.nlpsol``). ``--save-before`` stores the solution (objective, contact loads, activations, excitations)
of the code as it is; without it, the solution is compared with the stored one: the objective's relative
difference (the objective recomputed here from the solution, trapezoidal weights, not read from the solver)
and the largest difference of any contact load (medial, lateral, total) at any frame, in body weights
(preregistration C17: 1e-6 relative and 1e-3 BW). The stored file also holds the solve's inputs (``t, Qc, R, A,
F0``, keyword arguments, body weight), and the comparison solves on those: the knee model keeps changing (muscle
paths refitted, passive moments), which changes the optimum without any change of the solver; a note says when
the knee command's inputs of today differ from the stored ones. ``--data``: the folder with IK/, GRF/, KCF/ of the JW trials
(ReducePoly_forMSK at 0b5ecfa, ExampleTrackingSimulations/OpenSimModel/subject_GC) for bouncy7 and mtpgait3;
ngait_og5 is in the shared data.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # as the knee command (cli/knee.py), before NumPy loads
import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import ocp_constraints.biomech.knee_collocation as kc  # noqa: E402
from ocp_constraints.biomech.knee_pipeline import run_knee  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVE_WEIGHT, solve_static  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
SHARED = J / "reducepoly_subject_GC"
OUT = ROOT / "results" / "knee" / "collocation_speed"


def collocation_inputs(trial: str, data: Path) -> tuple[tuple, dict, float]:
    """``(t, Qc, R, A, F0)``, keyword arguments and body weight (N) of the knee command's collocation call."""
    calls = []

    def record(*args, **kwargs):            # the static solution stands in: only the inputs are wanted here
        calls.append((args, kwargs))
        return solve_static(*args, **kwargs)

    real = kc.solve_collocation
    kc.solve_collocation = record
    try:
        run = run_knee(MODEL, *[data / k / f"{k}_{trial}.mat" for k in ("IK", "GRF", "KCF")], method="collocation")
    finally:
        kc.solve_collocation = real
    (args, kwargs), = calls
    return args, kwargs, run["bw"]


def objective(t, res) -> float:
    """``sum_k w_k [sum_m (e^2 + a^2)/2 + W sum rho^2]``, trapezoidal ``w_k`` (the module docstring's J)."""
    h = np.diff(t)
    w = np.zeros(len(t))
    w[:-1] += 0.5 * h
    w[1:] += 0.5 * h
    per_frame = 0.5 * ((res.excitation ** 2).sum(1) + (res.activation ** 2).sum(1)) + RESERVE_WEIGHT * (res.reserve ** 2).sum(1)
    return float(w @ per_frame)


def timed_solve(args, kwargs) -> tuple:
    """The collocation solve with CPU / wall seconds and the IPOPT stats of its ``knee_col`` solver."""
    solvers = []
    real = ca.nlpsol

    def capture(name, *a, **k):
        s = real(name, *a, **k)
        if name.startswith("knee_col"):
            solvers.append(s)
        return s

    ca.nlpsol = capture
    try:
        cpu, wall = time.process_time(), time.perf_counter()
        res = kc.solve_collocation(*args, **kwargs)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    finally:
        ca.nlpsol = real
    stats = solvers[-1].stats() if solvers else {}
    return res, cpu, wall, stats


def option_value(text: str):
    """``--option`` values: numbers as numbers, anything else as the string."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def stored_inputs(before) -> tuple[tuple, dict, float]:
    """The ``(t, Qc, R, A, F0)``, keyword arguments and body weight saved with a 'before' solution."""
    args = tuple(before[k] for k in ("t", "Qc", "R", "A", "F0"))
    return args, {"muscles_on": bool(before["muscles_on"])}, float(before["bw"])


def same_inputs(a: tuple, b: tuple) -> bool:
    return all(np.shape(x) == np.shape(y) and np.allclose(x, y, rtol=1e-12, atol=1e-12) for x, y in zip(a, b))


def main(trial: str, data: Path, runs: int, save_before: Path | None, options: dict | None = None) -> None:
    args, kwargs, bw = collocation_inputs(trial, data)
    before = OUT / f"before_{trial}.npz"
    if save_before is None and before.exists() and "Qc" in np.load(before).files:
        stored = stored_inputs(np.load(before))
        if not same_inputs(args, stored[0]) or kwargs != stored[1]:
            print(f"  note: the knee command's inputs of today differ from those stored in {before} (the model "
                  "changed): the solve below uses the stored ones")
        args, kwargs, bw = stored
    if options:
        kwargs = {**kwargs, "ipopt_options": options}
        print(f"  IPOPT options: {options}")
    t = np.asarray(args[0], float)
    print(f"{trial}: {len(t)} frames, {args[2].shape[2]} muscles, body weight {bw:.2f} N")
    rows = []
    for _ in range(runs):
        res, cpu, wall, stats = timed_solve(args, kwargs)
        rows.append((cpu, wall))
        ipopt = {k: stats[k] for k in ("t_proc_total", "t_wall_total", "t_proc_nlp_f", "t_proc_nlp_g", "t_proc_nlp_grad_f",
                                       "t_proc_nlp_jac_g", "t_proc_nlp_hess_l") if k in stats}
        print(f"  solve_collocation: {cpu:.2f} s CPU, {wall:.2f} s wall; IPOPT {stats.get('iter_count')} iterations, "
              f"status {res.status}; timings {({k: round(v, 3) for k, v in res.timings.items()})}; "
              f"IPOPT stats {({k: round(v, 3) for k, v in ipopt.items()})}", flush=True)
    J = objective(t, res)
    loads = np.column_stack([res.medial, res.lateral, res.total])
    cpu, wall = np.median(np.array(rows), axis=0)
    print(f"  median of {runs}: {cpu:.2f} s CPU, {wall:.2f} s wall; objective {J:.12g}")
    if save_before is not None:
        save_before.parent.mkdir(parents=True, exist_ok=True)
        np.savez(save_before, t=t, objective=J, loads=loads, activation=res.activation, excitation=res.excitation,
                 reserve=res.reserve, cpu=cpu, wall=wall, iterations=stats.get("iter_count", -1), bw=bw,
                 Qc=args[1], R=args[2], A=args[3], F0=np.asarray(args[4], float),
                 muscles_on=bool(kwargs.get("muscles_on", True)), options=repr(options or {}))
        print(f"  saved as the 'before' solution: {save_before}")
        return
    if not before.exists():
        print(f"  no stored 'before' solution {before}: run with --save-before on the code before the change")
        return
    b = np.load(before)
    rel = abs(J - float(b["objective"])) / abs(float(b["objective"]))
    dload = float(np.abs(loads - b["loads"]).max()) / bw
    ok = rel <= 1e-6 and dload <= 1e-3
    print(f"  before: {float(b['cpu']):.2f} s CPU, {float(b['wall']):.2f} s wall, {int(b['iterations'])} iterations; "
          f"objective rel. difference {rel:.2e} (<= 1e-6), max contact-load difference {dload:.2e} BW (<= 1e-3), "
          f"max activation difference {np.abs(res.activation - b['activation']).max():.2e}: "
          + ("UNCHANGED" if ok else "CHANGED"))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", default="ngait_og5")
    ap.add_argument("--data", type=Path, default=SHARED, help="folder with IK/, GRF/, KCF/ (.mat) of the trial")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--save-before", type=Path, default=None)
    ap.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                    help="an extra casadi.nlpsol option for the collocation, e.g. ipopt.mumps_pivot_order=2 (candidates)")
    a = ap.parse_args()
    main(a.trial, a.data, a.runs, a.save_before, {k: option_value(v) for k, v in (o.split("=", 1) for o in a.option)})
