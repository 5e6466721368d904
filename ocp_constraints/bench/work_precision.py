"""``ocp-constraints bench``: run time against error, side by side with peers, in one run.

    ocp-constraints bench [SCENE ...] [--quick] [--target-error E] [--out DIR] [--runs N] [--no-scaling]

For every scene with a reference (see :mod:`ocp_constraints.bench.sweeps` and
:mod:`ocp_constraints.bench.references`): the optimal-control sweep (scheme x intervals)
and the simulation sweep (integrator x tolerance), the peers that are installed
(:mod:`ocp_constraints.bench.peers`), the scaling runs and the slow stress cases
(:mod:`ocp_constraints.bench.scaling`). Writes ``DIR/<scene>.csv``, ``DIR/<scene>.md``,
``DIR/<scene>_work_precision.png``, ``DIR/peers.md``, ``DIR/scaling.md``,
``DIR/summary.json`` and ``DIR/README_section.md``, and prints the cheapest setting
reaching ``--target-error``. From Python: :func:`recommend`.

The error of a setting is ``max(state error, multiplier error)``: the state error is
absolute (SI units), the multiplier error relative to the scene's load scale (the largest
reference multiplier). Benchmarks measure this machine; they are not tests.
"""
from __future__ import annotations

import csv
import platform
import statistics
import time
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from . import peers
from .defaults import DEFAULT_OUT
from .sweeps import OCP_TASKS, SIM_SCENES, Row

LAMBDA_TARGET = 1e-8
COLUMNS = [f.name for f in fields(Row)] + ["total_s"]


def error_of(row: Row) -> float:
    """``max(state error, multiplier error)``; NaN (no reference) counts as unreached."""
    e = max(row.state_err, row.lambda_err)
    return float("inf") if not np.isfinite(e) else e


def cheapest(rows: list[Row], target: float, key=error_of, kinds=("ocp", "sim")) -> Row | None:
    ok = [r for r in rows if r.kind in kinds and key(r) <= target and not r.status.startswith("stopped")]
    return min(ok, key=lambda r: r.total_s) if ok else None


def read_rows(path: Path) -> list[Row]:
    out = []
    with open(path, newline="") as f:
        for rec in csv.DictReader(f):
            rec.pop("total_s", None)
            kw = {}
            for fl in fields(Row):
                v = rec[fl.name]
                kw[fl.name] = int(float(v)) if fl.type in ("int", int) else (float(v) if fl.type in ("float", float) else v)
            out.append(Row(**kw))
    return out


def recommend(scene: str, target_error: float, out: str | Path = DEFAULT_OUT, kind: str = "ocp") -> dict | None:
    """The cheapest measured setting of ``scene`` (``kind`` "ocp" or "sim") whose error is at most ``target_error``.

    Reads ``out/<scene>.csv`` written by ``ocp-constraints bench``; returns the row as a
    dict (setting, times, errors) or None when no measured setting reaches the target.
    """
    path = Path(out) / f"{scene}.csv"
    if not path.is_file():
        raise FileNotFoundError(f"no benchmark results for '{scene}' in {out}: run 'ocp-constraints bench {scene}' first")
    row = cheapest(read_rows(path), target_error, kinds=(kind,))
    return None if row is None else {**asdict(row), "total_s": row.total_s, "error": error_of(row)}


# -- peers -----------------------------------------------------------------------------------
def _median_runs(fn, runs: int, *args) -> dict:
    results = [fn(*args) for _ in range(runs)]
    best = results[-1]
    best["build_s"] = statistics.median(r["build_s"] for r in results)
    best["solve_s"] = statistics.median(r["solve_s"] for r in results)
    return best


def run_peers(scenes, quick: bool, runs: int, log=print) -> tuple[list[Row], list[str]]:
    from .references import TIGHTEST_RTOL, pendulum_reference, swing_up_reference, integrator_reference
    from ..scenes.registry import load_scene_module

    rows, notes = [], []
    if "pendulum" in scenes:
        ref = swing_up_reference()
        grid = (20, 80) if quick else (10, 20, 40, 80, 160, 400)
        for name, module, fn in (("rockit", "rockit", peers.rockit_swing_up), ("drake", "pydrake", peers.drake_swing_up)):
            if not peers.available(module):
                notes.append(f"{name}: not installed (pip install -e .[bench]); skipped")
                log(f"  peer {name}: not installed, skipped")
                continue
            for N in grid:
                try:
                    r = _median_runs(fn, runs, N)
                except Exception as exc:  # a peer's failure is reported, never fatal
                    notes.append(f"{name} N={N}: failed: {type(exc).__name__}: {exc}")
                    continue
                psi, w = ref.states(r["t"])
                st = max(float(np.abs(r["psi"] - psi).max()), float(np.abs(r["psi_dot"] - w).max()))
                rows.append(Row("pendulum", "peer-ocp", r["setting"], name, N, r["build_s"], r["solve_s"], r["iterations"],
                                st, float("nan"), float("nan"), float("nan"), float("nan"), float("nan"), float("nan"),
                                "ok" if r.get("success", True) else "failed", "Pontryagin extremal (states at mesh points)"))
                log(f"  peer {r['setting']:<40} build {r['build_s']:.3f} s solve {r['solve_s']:.3f} s state {st:.1e}")
    sims = []
    if "pendulum" in scenes:
        sims.append(("pinocchio", "pinocchio", "pendulum", peers.pinocchio_pendulum))
    if "sliding_disk" in scenes:
        sims.append(("sympy", "sympy", "sliding_disk", peers.sympy_sliding_disk))
    t_final = 2.0 if quick else 10.0
    for name, module, scene, fn in sims:
        if not peers.available(module):
            notes.append(f"{name}: not installed; skipped")
            continue
        for rtol in ((1e-10,) if quick else (1e-6, 1e-8, 1e-10, 1e-12)):
            r = _median_runs(fn, runs, t_final, rtol)
            p = load_scene_module(scene).DEFAULTS
            rf = (pendulum_reference(p, r["t"], TIGHTEST_RTOL) if scene == "pendulum"
                  else integrator_reference(scene, r["t"], rtol=TIGHTEST_RTOL))
            scale = max(float(np.abs(v).max()) for v in rf["lambda"].values())
            st = max(float(np.abs(r["states"][k] - rf["states"][k]).max()) for k in r["states"] if k in rf["states"])
            le = max(float(np.abs(r["lambda"][k] - rf["lambda"][k]).max()) for k in rf["lambda"]) / scale
            rows.append(Row(scene, "peer-sim", r["setting"], name, rtol, r["build_s"], r["solve_s"], -1, st, le, float("nan"),
                            float("nan"), float("nan"), float("nan"), float("nan"), "ok", rf["method"]))
            log(f"  peer {r['setting']:<40} build {r['build_s']:.3f} s solve {r['solve_s']:.3f} s state {st:.1e} lambda {le:.1e}")
    return rows, notes


def peer_ratios(rows: list[Row]) -> list[dict]:
    """Per peer setting: our cheapest setting with equal or better error, and the time ratios."""
    out = []
    for p in rows:
        if not p.kind.startswith("peer"):
            continue
        kind = "ocp" if p.kind == "peer-ocp" else "sim"
        key = (lambda r: r.state_err) if kind == "ocp" else error_of
        target = p.state_err if kind == "ocp" else error_of(p)
        ours = cheapest([r for r in rows if r.scene == p.scene], target, key=key, kinds=(kind,))
        out.append({"scene": p.scene, "peer": p.setting, "peer_error": target, "peer_total_s": p.total_s, "peer_solve_s": p.solve_s,
                    "ours": None if ours is None else ours.setting, "our_error": None if ours is None else key(ours),
                    "ratio_total": None if ours is None else ours.total_s / p.total_s,
                    "ratio_solve": None if ours is None else ours.solve_s / p.solve_s})
    return out


# -- outputs ---------------------------------------------------------------------------------
def write_csv_rows(path: Path, rows: list[Row]) -> None:
    tmp = path.with_suffix(".tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([*(getattr(r, c) for c in COLUMNS[:-1]), r.total_s])
    tmp.replace(path)


def markdown_table(rows: list[Row]) -> str:
    head = "| setting | kind | build (s) | solve (s) | iterations | state error | lambda error (rel.) | lambda error at t0 | residuals pos / vel | status |\n|---|---|---|---|---|---|---|---|---|---|\n"
    body = "".join(
        f"| {r.setting} | {r.kind} | {r.build_s:.3f} | {r.solve_s:.3f} | {r.iterations if r.iterations >= 0 else ''} | "
        f"{r.state_err:.1e} | {r.lambda_err:.1e} | {r.lambda_err_t0:.1e} | {r.pos_residual:.0e} / {r.vel_residual:.0e} | {r.status[:40]} |\n"
        for r in rows)
    return head + body


def plot_work_precision(path: Path, scene: str, rows: list[Row]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(17, 4.5))
    for ax, attr, title in ((axes[0], "state_err", "state error (abs.)"), (axes[1], "lambda_err", "multiplier error (rel. to load scale)")):
        curves: dict[str, list[Row]] = {}
        for r in rows:
            curves.setdefault(f"{r.kind}: {r.scheme}", []).append(r)
        for label, rs in sorted(curves.items()):
            pts = sorted((r.total_s, getattr(r, attr)) for r in rs if np.isfinite(getattr(r, attr)) and getattr(r, attr) > 0)
            if pts:
                ax.loglog(*zip(*pts), "o-" if not label.startswith("peer") else "s--", label=label, ms=3)
        ax.set_xlabel("wall time, build + solve (s, median)")
        ax.set_ylabel(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=6, ncol=2)
    # Multiplier error against the tolerance asked for (simulations and simulating peers): where it
    # stops falling is the floor.
    ax = axes[2]
    for label, kinds in (("ours", ("sim",)), ("peer", ("peer-sim",))):
        by: dict[str, list] = {}
        for r in rows:
            if r.kind in kinds and np.isfinite(r.lambda_err) and r.lambda_err > 0:
                by.setdefault(f"{label}: {r.scheme}", []).append((r.resolution, r.lambda_err))
        for name, pts in sorted(by.items()):
            ax.loglog(*zip(*sorted(pts)), "o-" if label == "ours" else "s--", label=name, ms=3)
    if ax.lines:
        ax.invert_xaxis()
        ax.legend(fontsize=6)
    ax.set_xlabel("integrator tolerance rtol = atol")
    ax.set_ylabel("multiplier error (rel. to load scale)")
    ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"{scene}: work-precision")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_multiplier_floor(path: Path, rows: list[Row]) -> str:
    """Multiplier error against the tolerance asked for, every simulated scene in one figure (ours:
    Adams and BDF; the simulating peers dashed): where a curve stops falling is its floor. Returns a
    Markdown table of the same numbers (rows: tolerances; columns: scene and method)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        if r.kind in ("sim", "peer-sim") and np.isfinite(r.lambda_err) and r.lambda_err > 0:
            who = r.scheme if r.kind == "sim" else f"peer {r.scheme}"
            curves.setdefault(f"{r.scene}: {who}", []).append((r.resolution, r.lambda_err))
    fig, ax = plt.subplots(figsize=(8, 5.5))
    scenes = sorted({name.split(":")[0] for name in curves})
    colour = {sc: plt.get_cmap("tab10")(k % 10) for k, sc in enumerate(scenes)}   # one colour a scene
    for name, pts in sorted(curves.items()):
        style = "s--" if "peer" in name else ("o-" if "adams" in name else "^:")   # one style a method
        ax.loglog(*zip(*sorted(pts)), style, color=colour[name.split(":")[0]], label=name, ms=3)
    if ax.lines:
        ax.invert_xaxis()
        ax.legend(fontsize=6, ncol=2)
    ax.set_xlabel("integrator tolerance rtol = atol")
    ax.set_ylabel("max multiplier error, relative to the load scale")
    ax.set_title("Multiplier error against tolerance, every simulated scene (10 s)")
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    tols = sorted({t for pts in curves.values() for t, _ in pts}, reverse=True)
    names = sorted(curves)
    table = ["| rtol | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for t in tols:
        cells = [next((f"{e:.1e}" for tt, e in curves[n] if tt == t), "") for n in names]
        table.append(f"| {t:g} | " + " | ".join(cells) + " |")
    return "\n".join(table) + "\n"


def machine() -> dict:
    import os

    import casadi

    return {"python": platform.python_version(), "casadi": casadi.__version__, "cpus": os.cpu_count(),
            "processor": platform.processor() or platform.machine(), "date": time.strftime("%Y-%m-%d %H:%M")}


__all__ = ["recommend", "plot_multiplier_floor", "OCP_TASKS", "SIM_SCENES"]
