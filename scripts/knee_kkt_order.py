"""The knee collocation's NLP in other, exactly equivalent forms: order of unknowns and rows, SX expansion, orderings.

    python scripts/knee_kkt_order.py [--trials ngait_og5 bouncy7 mtpgait3] [--data DIR] [--runs 1]
        [--candidates NAME ...] [--estimate-only]

Each candidate solves the same NLP as :func:`knee_collocation.solve_collocation` (on the inputs stored with the
reference solution in ``results/knee/collocation_speed/before_<trial>.npz``), transformed on the way to IPOPT
(``casadi.nlpsol`` intercepted):

- ``expand``: the NLP's MX graph expanded to SX (``expand: True``): the same expressions, evaluated
  (Jacobian, Hessian) on CasADi's SX virtual machine;
- ``unknowns muscle-major`` / ``rows by frame`` / both: the unknowns ``x = P y`` (``y`` IPOPT's) and the
  constraint rows permuted; MUMPS's ordering starts from another matrix (ties broken elsewhere), IPOPT's
  iterates are the same up to rounding;
- ``METIS`` / ``PORD`` / ``QAMD`` / ``AMD`` / ``SCOTCH``: another fill-reducing ordering of MUMPS;
- ``MUMPS scaling 0``: no scaling of the KKT matrix (IPOPT's default 77 lets MUMPS choose: a simultaneous
  row/column scaling, recomputed at every factorization, ~4 % of the solve's samples under ``perf``).

``--runs N``: the candidates in turn, N rounds, so that a change of the machine's load hits all alike.

For each: MUMPS's operation count of one factorization of the first KKT matrix (its analysis, printed by
IPOPT at mumps_print_level 2: exact, not timed), IPOPT iterations, CPU (``time.process_time``) and wall seconds
of the solve, and the check of knee_collocation_speed.py: objective to 1e-6 relative, every contact load to
1e-3 BW at every frame, against the stored reference.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from knee_collocation_speed import OUT, SHARED, objective, stored_inputs  # noqa: E402

import ocp_constraints.biomech.knee_collocation as kc  # noqa: E402

ORDERINGS = {"AMD": 0, "SCOTCH": 3, "PORD": 4, "METIS": 5, "QAMD": 6}


def permutations(nlp: dict, shape: dict, unknowns: str, rows: str) -> tuple[np.ndarray, np.ndarray]:
    """``perm`` (``y = x[perm]``) and ``rowperm`` (``g_new = g[rowperm]``) of the collocation's NLP."""
    N, nm, nx, nr = shape["N"], shape["nm"], shape["nx"], shape["nr"]
    idx = np.arange(nx * N).reshape(N, nx)           # frame-major: x[k * nx + j]
    if unknowns == "muscle-major":                    # per muscle a_m, e_m over the frames, then the rest by frame
        a, e = idx[:, :nm], idx[:, nm:2 * nm]
        perm = np.concatenate([np.column_stack([a[:, m], e[:, m]]).ravel() for m in range(nm)]
                              + [idx[:, 2 * nm:].ravel()])
    elif unknowns == "frame, a e interleaved":        # per frame (a_1, e_1, a_2, e_2, ..., lambda, rho)
        perm = np.concatenate([np.concatenate([np.column_stack([idx[k, :nm], idx[k, nm:2 * nm]]).ravel(),
                                               idx[k, 2 * nm:]]) for k in range(N)])
    else:
        perm = idx.ravel()
    bal = np.arange(N * nr).reshape(N, nr)
    dfc = N * nr + np.arange(N * nm).reshape(N, nm)   # ca.vec(defect): frame-major too
    rowperm = np.concatenate([np.concatenate([bal[k], dfc[k]]) for k in range(N)]) if rows == "by frame" \
        else np.arange(N * (nr + nm))
    return perm, rowperm


class Permuted:
    """An nlpsol solver on ``y = x[perm]``, ``g[rowperm]`` that takes and returns the original ``x``."""

    def __init__(self, nlpsol, name, plugin, nlp, opts, perm, rowperm):
        self.perm, self.inv = perm, np.argsort(perm)
        F = ca.Function("orig", [nlp["x"]], [nlp["f"], nlp["g"]])
        Y = ca.MX.sym("Y", len(perm))
        f, g = F(Y[self.inv.tolist()])
        self.solver = nlpsol(name, plugin, {"x": Y, "f": f, "g": g[rowperm.tolist()]}, {**opts, "expand": True})

    def __call__(self, x0, lbx, ubx, lbg, ubg):
        sol = self.solver(x0=np.asarray(x0)[self.perm], lbx=np.asarray(lbx)[self.perm],
                          ubx=np.asarray(ubx)[self.perm], lbg=lbg, ubg=ubg)
        return {**sol, "x": np.asarray(sol["x"]).ravel()[self.inv]}

    def stats(self):
        return self.solver.stats()


def candidate_solver(name: str, shape: dict):
    """A replacement for ``casadi.nlpsol`` that builds candidate ``name`` of the ``knee_col`` NLP."""
    real = ca.nlpsol

    def build(nm_, plugin, nlp, opts):
        if not nm_.startswith("knee_col"):
            return real(nm_, plugin, nlp, opts)
        opts = dict(opts)
        if name in ORDERINGS:
            opts["ipopt.mumps_pivot_order"] = ORDERINGS[name]
        if name == "MUMPS scaling 0":               # no scaling of the KKT matrix (default 77: MUMPS's choice)
            return real(nm_, plugin, nlp, {**opts, "ipopt.mumps_scaling": 0})
        if name == "expand":
            return real(nm_, plugin, nlp, {**opts, "expand": True})
        if name in ("module default",) or name in ORDERINGS:
            return real(nm_, plugin, nlp, opts)
        unknowns = ("muscle-major" if "muscle-major" in name else "frame, a e interleaved" if "interleaved" in name
                    else "frame-major")
        rows = "by frame" if "rows by frame" in name else "as built"
        perm, rowperm = permutations(nlp, shape, unknowns, rows)
        return Permuted(real, nm_, plugin, nlp, opts, perm, rowperm)
    return build


CANDIDATES = ["module default", "expand", "unknowns muscle-major", "rows by frame", "unknowns muscle-major, rows by frame",
              "unknowns interleaved", "unknowns interleaved, rows by frame", *ORDERINGS, "MUMPS scaling 0"]


def run(name: str, args, kwargs, estimate: bool, shape: dict):
    """``(result, cpu, wall, stats, mumps_text)`` of one solve of candidate ``name``."""
    real, solvers = ca.nlpsol, []
    make = candidate_solver(name, shape)

    def capture(*a):
        s = make(*a)
        if a[0].startswith("knee_col"):
            solvers.append(s)
        return s
    ca.nlpsol = capture
    extra = {"ipopt.max_iter": 0, "ipopt.mumps_print_level": 2, "ipopt.print_level": 3} if estimate else {}
    text = ""
    try:
        with tempfile.TemporaryFile(mode="w+b") as tmp:
            sys.stdout.flush()
            saved = os.dup(1)
            if estimate:
                os.dup2(tmp.fileno(), 1)
            try:
                cpu, wall = time.process_time(), time.perf_counter()
                res = kc.solve_collocation(*args, **kwargs, ipopt_options=extra)
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
            except Exception:  # noqa: BLE001 - 0 iterations end as a failure: only MUMPS's text is wanted
                res, cpu, wall = None, float("nan"), float("nan")
            finally:
                os.dup2(saved, 1)
                os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode(errors="replace")
    finally:
        ca.nlpsol = real
    return res, cpu, wall, (solvers[-1].stats() if solvers else {}), text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", nargs="+", default=["ngait_og5", "bouncy7", "mtpgait3"])
    ap.add_argument("--data", type=Path, default=SHARED)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--candidates", nargs="+", default=CANDIDATES, choices=CANDIDATES, metavar="NAME")
    ap.add_argument("--estimate-only", action="store_true", help="MUMPS's operation counts only (no solve)")
    a = ap.parse_args()
    print("| trial | candidate | MUMPS flops / factorization | largest front | iterations | solve CPU s, median (least) "
          "| solve wall s, median (least) | objective rel. diff. | max load diff. BW | same optimum |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for trial in a.trials:
        b = np.load(OUT / f"before_{trial}.npz")
        args, kwargs, bw = stored_inputs(b)
        t = np.asarray(args[0], float)
        N, nr, nm = args[2].shape
        shape = {"N": N, "nr": nr, "nm": nm, "nx": 2 * nm + 5 + len(kc.RESERVED)}
        est, rows, last = {}, {name: [] for name in a.candidates}, {}
        for name in a.candidates:
            _, _, _, _, text = run(name, args, kwargs, True, shape)
            flops = re.search(r"RINFOG\(1\) Operations during elimination \(estim\)\s*=\s*([0-9.D+E-]+)", text)
            front = re.search(r"Maximum frontal size\s+\(estimated\)\s*=\s*(\d+)", text)
            est[name] = (float(flops.group(1).replace("D", "E")) if flops else float("nan"), front.group(1) if front else "?")
            if a.estimate_only:
                print(f"| {trial} | {name} | {est[name][0]:.3g} | {est[name][1]} | | | | | | |", flush=True)
        if a.estimate_only:
            continue
        for _ in range(a.runs):            # the candidates in turn, run after run: a change of load hits all alike
            for name in a.candidates:
                res, cpu, wall, stats, _ = run(name, args, kwargs, False, shape)
                rows[name].append((cpu, wall))
                last[name] = (res, stats)
        for name in a.candidates:
            (flops, front), (res, stats) = est[name], last[name]
            J = objective(t, res)
            rel = abs(J - float(b["objective"])) / abs(float(b["objective"]))
            dload = float(np.abs(np.column_stack([res.medial, res.lateral, res.total]) - b["loads"]).max()) / bw
            cpus, walls = sorted(r[0] for r in rows[name]), sorted(r[1] for r in rows[name])
            ok = rel <= 1e-6 and dload <= 1e-3
            print(f"| {trial} | {name} | {flops:.3g} | {front} | {stats.get('iter_count')} | "
                  f"{cpus[len(cpus) // 2]:.2f} ({cpus[0]:.2f}) | {walls[len(walls) // 2]:.2f} ({walls[0]:.2f}) | "
                  f"{rel:.1e} | {dload:.1e} | {'UNCHANGED' if ok else 'CHANGED'} |", flush=True)


if __name__ == "__main__":
    main()
