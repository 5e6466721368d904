"""The knee collocation's KKT solves: MUMPS settings and BLAS threads, timed and checked for the same optimum.

    python scripts/knee_collocation_kkt.py [--trials ngait_og5 bouncy7 mtpgait3] [--data DIR] [--runs 3]
        [--candidates NAME ...] [--blas-threads 1]

IPOPT spends about 90 % of the collocation's solve in its linear algebra (MUMPS factorizations of the KKT
matrix, ``print_timing_statistics``: ComputeSearchDirection). Each candidate is a set of IPOPT options
passed to :func:`solve_collocation` (``ipopt_options``, added to the module's own). Per trial and candidate:

- MUMPS's own estimate of the factorization (``mumps_print_level=2`` on a zero-iteration solve, IPOPT's
  output captured at the file-descriptor level): operations per factorization (RINFOG(1)), entries in the
  factors, largest front, the ordering MUMPS used. These do not depend on the machine's load;
- the solve's CPU (``time.process_time``) and wall seconds, median and least of ``--runs`` runs taken round-robin over
  the candidates (so that a change of the machine's load hits all of them alike), IPOPT iterations;
- whether the solution is the stored one (``results/knee/collocation_speed/before_<trial>.npz``, written by
  ``scripts/knee_collocation_speed.py --save-before``): objective to 1e-6 relative and every contact load to
  1e-3 BW at every frame (preregistration C17), solved on the inputs stored with it. A candidate counts only
  if it is UNCHANGED on every trial.

``--blas-threads N``: the OpenBLAS that CasADi ships (MUMPS's dense kernels) runs N threads during the solves,
set with its ``openblas_set_num_threads`` and put back afterwards. Writes nothing; paste the table.
"""
from __future__ import annotations

import argparse
import ctypes
import os

os.environ.setdefault("GFORTRAN_UNBUFFERED_PRECONNECTED", "y")   # MUMPS's printout leaves while it is captured
import re
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # as the knee command (cli/knee.py), before NumPy loads
import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from knee_collocation_speed import OUT, SHARED, collocation_inputs, objective, stored_inputs, timed_solve  # noqa: E402

import ocp_constraints.biomech.knee_collocation as kc  # noqa: E402

# IPOPT's own defaults of every option a candidate sets, so that each candidate is the same whatever
# knee_collocation.KKT_OPTIONS holds ("module default": exactly what solve_collocation uses now)
IPOPT_DEFAULTS = {"ipopt.mumps_mem_percent": 1000, "ipopt.mumps_permuting_scaling": 7, "ipopt.mumps_pivot_order": 7,
                  "ipopt.mumps_scaling": 77, "ipopt.min_refinement_steps": 1}
CHANGES = {
    "IPOPT's defaults (before)": {},
    "mem_percent 100": {"ipopt.mumps_mem_percent": 100},
    "permuting_scaling 0": {"ipopt.mumps_permuting_scaling": 0},
    "mem 100, permuting 0": {"ipopt.mumps_mem_percent": 100, "ipopt.mumps_permuting_scaling": 0},
    "mem 100, permuting 0, AMD": {"ipopt.mumps_mem_percent": 100, "ipopt.mumps_permuting_scaling": 0,
                                  "ipopt.mumps_pivot_order": 0},
    "mem 100, permuting 0, AMF": {"ipopt.mumps_mem_percent": 100, "ipopt.mumps_permuting_scaling": 0,
                                  "ipopt.mumps_pivot_order": 2},
    "mem 100, permuting 0, AMF, min refinement 0": {
        "ipopt.mumps_mem_percent": 100, "ipopt.mumps_permuting_scaling": 0, "ipopt.mumps_pivot_order": 2,
        "ipopt.min_refinement_steps": 0},
    "mem 100, permuting 0, METIS": {"ipopt.mumps_mem_percent": 100, "ipopt.mumps_permuting_scaling": 0,
                                    "ipopt.mumps_pivot_order": 5},
    "mem 100, scaling 0": {"ipopt.mumps_mem_percent": 100, "ipopt.mumps_scaling": 0},
}
CANDIDATES = {name: {**IPOPT_DEFAULTS, **change} for name, change in CHANGES.items()}
CANDIDATES["module default"] = dict(getattr(kc, "KKT_OPTIONS", {}))
# IPOPT's inertia-free curvature test (Chiang & Zavala 2014, ``neg_curv_test_tol``; 1e-12..1e-11 recommended):
# wrong inertia is ignored where the step has positive curvature, saving the re-factorization
for tol in ("1e-12", "1e-11"):
    CANDIDATES[f"module default, neg_curv_test_tol {tol}"] = {**CANDIDATES["module default"],
                                                               "ipopt.neg_curv_test_tol": float(tol)}
MUMPS_FIELDS = {"flops": r"RINFOG\(1\) Operations during elimination \(estim\)\s*=\s*([0-9.D+E-]+)",
                "factor_entries": r"Number of entries in factors \(estim\.\)\s*=\s*(\d+)",
                "max_front": r"Maximum frontal size\s+\(estimated\)\s*=\s*(\d+)",
                "ordering": r"Ordering option effectively used\s*=\s*(\d+)"}
ORDERINGS = {"0": "AMD", "2": "AMF", "3": "SCOTCH", "4": "PORD", "5": "METIS", "6": "QAMD"}


def casadi_openblas():
    """CasADi's own OpenBLAS (the one MUMPS calls), or None if this CasADi has none."""
    path = Path(ca.__file__).parent / "libcasadi-tp-openblas.so.0"
    return ctypes.CDLL(str(path)) if path.exists() else None


def mumps_estimate(args, kwargs, options: dict) -> dict:
    """MUMPS's analysis of the first KKT matrix: IPOPT's stdout (C level) captured during a 0-iteration solve."""
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        sys.stdout.flush()
        saved = os.dup(1)
        os.dup2(tmp.fileno(), 1)
        try:
            kc.solve_collocation(*args, **kwargs, print_level=3, ipopt_options={
                **options, "ipopt.max_iter": 0, "ipopt.mumps_print_level": 2})
        except Exception:  # noqa: BLE001 - 0 iterations end as 'Maximum_Iterations_Exceeded': only the text is wanted
            pass
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        tmp.seek(0)
        text = tmp.read().decode(errors="replace")
    out = {}
    for key, pattern in MUMPS_FIELDS.items():
        m = re.search(pattern, text)
        out[key] = m.group(1).replace("D", "E") if m else "?"
    out["ordering"] = ORDERINGS.get(out["ordering"], out["ordering"])
    return out


def check(trial: str, t, res, bw: float) -> tuple[float, float, bool]:
    b = np.load(OUT / f"before_{trial}.npz")
    J = objective(t, res)
    rel = abs(J - float(b["objective"])) / abs(float(b["objective"]))
    loads = np.column_stack([res.medial, res.lateral, res.total])
    dload = float(np.abs(loads - b["loads"]).max()) / bw
    return rel, dload, rel <= 1e-6 and dload <= 1e-3


def main(trials, data: Path, runs: int, names, blas_threads: int | None) -> None:
    blas = casadi_openblas()
    if blas_threads is not None:
        if blas is None:
            raise SystemExit("this CasADi ships no OpenBLAS of its own: --blas-threads cannot be set")
        previous = blas.openblas_get_num_threads()
        blas.openblas_set_num_threads(blas_threads)
    if blas is not None:
        blas.openblas_get_config.restype = ctypes.c_char_p
        print(f"CasADi's BLAS: {blas.openblas_get_config().decode()}, {blas.openblas_get_num_threads()} thread(s)")
    try:
        rows = []
        for trial in trials:
            before = np.load(OUT / f"before_{trial}.npz")
            if "Qc" in before.files:      # the inputs the reference was solved on (the model keeps changing)
                args, kwargs, bw = stored_inputs(before)
            else:
                args, kwargs, bw = collocation_inputs(trial, SHARED if trial == "ngait_og5" else data)
            t = np.asarray(args[0], float)
            est = {n: mumps_estimate(args, kwargs, CANDIDATES[n]) for n in names}
            times = {n: [] for n in names}
            result = {}
            for _ in range(runs):
                for n in names:
                    res, cpu, wall, stats = timed_solve(args, {**kwargs, "ipopt_options": CANDIDATES[n]})
                    times[n].append((cpu, wall))
                    result[n] = (res, stats.get("iter_count", -1) if stats else res.iterations)
            for n in names:
                res, _ = result[n]
                rel, dload, same = check(trial, t, res, bw)
                cpu, wall = np.median(np.array(times[n]), axis=0)
                low = np.min(np.array(times[n]), axis=0)
                e = est[n]
                rows.append(f"| {trial} | {n} | {float(e['flops']):.3g} | {e['factor_entries']} | {e['max_front']} | "
                            f"{e['ordering']} | {res.iterations} | {cpu:.2f} ({low[0]:.2f}) | {wall:.2f} ({low[1]:.2f}) | {rel:.1e} | {dload:.1e} | "
                            f"{'UNCHANGED' if same else 'CHANGED'} |")
                print(rows[-1], flush=True)
    finally:
        if blas_threads is not None:
            blas.openblas_set_num_threads(previous)
    print(f"\nload average at the end: {os.getloadavg()[0]:.1f}; runs per cell: {runs} (median)\n")
    print("| trial | candidate | MUMPS flops / factorization | factor entries | largest front | ordering | iterations "
          "| solve CPU s, median (least) | solve wall s, median (least) | objective rel. diff. | max load diff. BW | same optimum |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", nargs="+", default=["ngait_og5", "bouncy7", "mtpgait3"])
    ap.add_argument("--data", type=Path, default=SHARED, help="folder with IK/, GRF/, KCF/ of bouncy7 and mtpgait3")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--candidates", nargs="+", default=list(CANDIDATES), choices=list(CANDIDATES), metavar="NAME")
    ap.add_argument("--blas-threads", type=int, default=None)
    a = ap.parse_args()
    main(a.trials, a.data, a.runs, a.candidates, a.blas_threads)
