"""Textbook holdouts for accuracy on request (issue 19): ``problem.solve(tolerance=...)`` measured against
independent references on three problems written from scratch through the public API (``import
ocp_constraints as oc``), none used to tune the refinement.

    python scripts/refinement_holdouts.py [--tolerances 1e-3 1e-4 1e-5 1e-6] [--problems bang_bang clipped hinge]
        [--cpu-cap 120] [--no-fixed] [--out results/bench/refinement_holdouts.md]

Problems (rigid bodies with hand-written constraints, paper eq. 25, so the NLP is in maximal coordinates and
every multiplier is a constraint force or moment, eq. 26, checked against Newton-Euler by hand):

- ``bang_bang``: a block on a rail pushed by F (|F| <= F_MAX) at a point H above its center, rest to rest over D
  in minimum time. Closed form: F = F_MAX up to T/2, -F_MAX after, T = 2 sqrt(M D / F_MAX); the rail's normal
  force is M g and its moment about E3 is H F (it balances the push's moment): a multiplier that jumps.
- ``clipped``: the same block, rest to rest over D in a fixed T, least integral of F^2 with |F| <= U below the
  unconstrained peak 6 M D / T^2: F = clip(c2 (T/2 - t), -U, U) (Pontryagin: the saturated linear costate);
  c2 by root-finding on x(T) = D (brentq on the exact piecewise-polynomial integral). F kinks at the junctions.
- ``hinge``: a rod of mass M and length L turning about the fixed vertical axis E3 through its end A (three
  hinge forces and two hinge moments written in the fixed basis), driven by a torque tau about E3; a full turn
  rest to rest in T, least integral of tau^2, with the hinge's radial (centripetal) force bounded: a path
  constraint on the multipliers, M (L/2) omega^2 <= M (L/2) W^2, active along the middle of the turn. Closed form
  (the minimum-effort double integrator under a speed limit): alpha = A (T1 - t) up to T1 = 1.5 (T - THETA / W),
  A = 2 W / T1^2, then 0 at the limit, then mirrored; tau = J_A alpha, J_A = M L^2 / 3; hinge force on the rod
  along the rod -M (L/2) omega^2, across it M (L/2) alpha, vertical M g; hinge moment -M g (L/2) e2.

True errors are measured as the estimate defines its quantities (ocp/error_estimate.py's notes), on 4 times per
collocation point of every interval of the final mesh, the reference at the same fraction of its horizon
(as the estimate compares its companion; at a sample on a jump, the nearer of its two sides): states absolute (all 12 coordinates and speeds, SI),
multipliers relative to the reference's largest |lambda|, inputs relative to the reference's largest |input|,
both without t = 0, and (as the estimate does) without the jump windows the record names; the multipliers'
and inputs' error over every t > 0 is shown too. Each refined solve runs in its own process under a CPU cap
(RLIMIT_CPU); CPU is ``time.process_time`` of ``problem.solve`` (after one untimed warm-up solve of a
separate problem instance in the same process, which pays CasADi's first-use costs), wall beside it. The
fixed meshes are uniform Radau 3/5/7 on 5-160 intervals, cold-started, in one process per problem; the
cheapest is the one of least CPU whose true errors (states, multipliers and inputs over every t > 0, final
time) are at most the tolerance (the inputs are not gated by the refinement, but a fixed mesh is judged on
what it delivers; the column shows the cheapest on states and multipliers alone too).
"""
from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import os
import resource
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np
from scipy.interpolate import PPoly
from scipy.optimize import brentq

import ocp_constraints as oc

ROOT = Path(__file__).resolve().parents[1]
G = 9.81
E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])
PER_POINT = 4
FIXED_DEGREES = (3, 5, 7)
FIXED_INTERVALS = (5, 10, 20, 40, 80, 160)

# -- bang_bang and clipped: a block on a rail -----------------------------------------------------------------
M, H = 1.0, 1.0                      # kg; m: height of the push's point above the center of mass
BB_D, BB_FMAX = 1.0, 5.0             # m, N
BB_T = 2.0 * math.sqrt(M * BB_D / BB_FMAX)
CL_D, CL_T, CL_U = 4.0, 2.0, 5.0     # m, s, N (unconstrained peak 6 M D / T^2 = 6 N)
# -- hinge: a rod turning about E3 ------------------------------------------------------------------------------
ROD_M, ROD_L = 1.0, 1.0              # kg, m
HG_THETA, HG_T, HG_W = 2 * math.pi, 2.0, 4.0     # rad, s, rad/s (unconstrained peak 1.5 THETA / T = 4.71 rad/s)
J_A = ROD_M * ROD_L**2 / 3


def _block_model(name: str):
    """A block of mass M on a rail along E1 (gravity -E2 presses it on the rail; it does not turn), pushed
    along E1 by input F at the point H above its center. Returns the model and the push's point."""
    model = oc.Model(name, gravity=(0.0, -G, 0.0))
    block = model.add_body("block", M, np.diag([0.01, 0.01, 0.01]), rotation="321")
    model.add_constraint("rail.v2", ca.dot(E2, block.com.v), joint="rail", position=block.com.position[1])
    model.add_constraint("rail.v3", ca.dot(E3, block.com.v), joint="rail", position=block.com.position[2])
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"rail.w{k + 1}", ca.dot(E, block.omega), joint="rail")
    push = block.point("P", (0.0, H, 0.0))
    model.add_force("push", push, ca.vertcat(model.add_input("F"), 0, 0))
    return model


def bang_bang_problem() -> oc.OptimalControlProblem:
    """Minimum-time rest-to-rest of the block over BB_D with |F| <= BB_FMAX (free final time)."""
    ocp = oc.OptimalControlProblem(_block_model("holdout_bang_bang"), t_final=1.5, t_final_bounds=(0.2, 5.0))
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
    ocp.final({"block.x": BB_D, "block.vbar_x": 0.0})
    ocp.bound("F", -BB_FMAX, BB_FMAX)
    ocp.minimize_final_time()
    return ocp


def clipped_problem() -> oc.OptimalControlProblem:
    """Least integral of F^2, rest to rest over CL_D in CL_T, |F| <= CL_U (saturated at both ends)."""
    ocp = oc.OptimalControlProblem(_block_model("holdout_clipped"), t_final=CL_T)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
    ocp.final({"block.x": CL_D, "block.vbar_x": 0.0})
    ocp.bound("F", -CL_U, CL_U)
    ocp.minimize_effort(["F"])
    return ocp


def hinge_problem() -> oc.OptimalControlProblem:
    """A rod (center of mass L/2 from its end A on the axis) turning one full turn about E3 in HG_T, rest to
    rest, least integral of tau^2, the hinge's radial force at most ROD_M (L/2) HG_W^2 (a path constraint on
    the multipliers: the rod's speed limit seen through the load that holds it on its circle)."""
    model = oc.Model("holdout_hinge", gravity=(0.0, 0.0, -G))
    # A slender rod along its body axis e1 (1e-4 kg m^2 about it keeps the inertia positive definite).
    rod = model.add_body("rod", ROD_M, np.diag([1e-4, ROD_M * ROD_L**2 / 12, ROD_M * ROD_L**2 / 12]), rotation="321")
    A = rod.point("A", (-ROD_L / 2, 0.0, 0.0))
    # The hinge: A stays at the origin, the rod turns about E3 only (fixed-basis components, as cart_pole_by_hand).
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"hinge.v{k + 1}", ca.dot(E, A.v), joint="hinge", position=A.position[k])
    model.add_constraint("hinge.w1", ca.dot(E1, rod.omega), joint="hinge")
    model.add_constraint("hinge.w2", ca.dot(E2, rod.omega), joint="hinge")
    model.add_torque("drive", rod, ca.vertcat(0, 0, model.add_input("tau")))
    ocp = oc.OptimalControlProblem(model, t_final=HG_T)
    ocp.initial({"rod.psi": 0.0, "rod.theta": 0.0, "rod.phi": 0.0, "rod.omega_z": 0.0})
    ocp.final({"rod.psi": HG_THETA, "rod.omega_z": 0.0})
    psi = ocp.quantity("rod.psi")
    # The hinge force on the rod along the rod (e1 = cos psi E1 + sin psi E2): the centripetal load, negative.
    radial = ocp.multiplier("hinge.v1") * ca.cos(psi) + ocp.multiplier("hinge.v2") * ca.sin(psi)
    ocp.subject_to(-radial, -np.inf, ROD_M * ROD_L / 2 * HG_W**2, "hinge radial force")
    ocp.set_guess("rod.psi", lambda t: HG_THETA * np.asarray(t) / HG_T)
    ocp.minimize_effort(["tau"])
    return ocp


# -- references -------------------------------------------------------------------------------------------------
def _integrated(breaks, pieces) -> tuple[PPoly, PPoly, PPoly]:
    """A piecewise polynomial (``pieces``: highest-power-first local coefficients per piece) and its first and
    second antiderivatives from 0, exact (scipy's PPoly keeps each piece's polynomial)."""
    p = PPoly(np.array(pieces, dtype=float).T, np.asarray(breaks, dtype=float))
    return p, p.antiderivative(1), p.antiderivative(2)


def _clipped_switch(c2: float) -> float:
    """Where the clipped line c2 (T/2 - t) leaves the bound U."""
    return CL_T / 2 - CL_U / c2


def _clipped_push(c2: float) -> tuple[PPoly, PPoly, PPoly]:
    t1 = _clipped_switch(c2)
    return _integrated([0.0, t1, CL_T - t1, CL_T],
                       [[0.0, CL_U / M], [-c2 / M, CL_U / M], [0.0, -CL_U / M]])


def clipped_c2() -> float:
    """c2 of F = clip(c2 (T/2 - t), -U, U) with x(T) = D: brentq on the exact x(T) of the clipped line."""
    lo = 2 * CL_U / CL_T * (1 + 1e-12)           # just saturating at t = 0
    return brentq(lambda c2: float(_clipped_push(c2)[2](CL_T)) - CL_D, lo, 1e6 * lo, xtol=1e-15, rtol=1e-15)


def _hinge_law() -> tuple[float, float]:
    t1 = 1.5 * (HG_T - HG_THETA / HG_W)
    return t1, 2 * HG_W / t1**2


@dataclass
class Reference:
    """Every named quantity as a function of absolute time (s), and what the solve must give."""
    values: Callable[[np.ndarray], dict[str, np.ndarray]]
    t_final: float
    objective: float
    free_time: bool
    switches: tuple[float, ...]      # times (s) where the input jumps or kinks


def _block_values(accel: tuple[PPoly, PPoly, PPoly], T: float) -> Callable:
    def values(t):
        t = np.clip(np.asarray(t, float), 0.0, T)
        a, v, x = (np.asarray(f(t)) for f in accel)
        F = M * a
        z = 0 * t
        out = {n: z for n in ("block.y", "block.z", "block.psi", "block.theta", "block.phi", "block.vbar_y",
                              "block.vbar_z", "block.omega_x", "block.omega_y", "block.omega_z")}
        # Newton-Euler on the block (no rotation): along E2 the rail holds the weight; about E3 at the center
        # its moment balances the push's, (H E2) x (F E1) = -H F E3.
        out.update({"block.x": x, "block.vbar_x": v, "F": F, "rail.v2.lambda": M * G + z, "rail.v3.lambda": z,
                    "rail.w1.lambda": z, "rail.w2.lambda": z, "rail.w3.lambda": H * F})
        return out
    return values


def bang_bang_reference() -> Reference:
    T = BB_T
    accel = _integrated([0.0, T / 2, T], [[BB_FMAX / M], [-BB_FMAX / M]])
    return Reference(_block_values(accel, T), T, T, True, (T / 2,))


def clipped_reference() -> Reference:
    c2 = clipped_c2()
    t1 = _clipped_switch(c2)
    J = 2 * (CL_U**2 * t1 + c2**2 * (CL_T / 2 - t1) ** 3 / 3)
    return Reference(_block_values(_clipped_push(c2), CL_T), CL_T, J, False, (t1, CL_T - t1))


def hinge_reference() -> Reference:
    t1, A = _hinge_law()
    alpha, omega, theta = _integrated([0.0, t1, HG_T - t1, HG_T], [[-A, A * t1], [0.0, 0.0], [-A, 0.0]])
    r = ROD_L / 2

    def values(t):
        t = np.clip(np.asarray(t, float), 0.0, HG_T)
        al, om, th = (np.asarray(f(t)) for f in (alpha, omega, theta))
        c, s, z = np.cos(th), np.sin(th), 0 * t
        along, across = -ROD_M * r * om**2, ROD_M * r * al          # hinge force on the rod along e1, e2
        return {"rod.x": r * c, "rod.y": r * s, "rod.z": z, "rod.psi": th, "rod.theta": z, "rod.phi": z,
                "rod.vbar_x": -r * om * s, "rod.vbar_y": r * om * c, "rod.vbar_z": z,
                "rod.omega_x": z, "rod.omega_y": z, "rod.omega_z": om, "tau": J_A * al,
                "hinge.v1.lambda": along * c - across * s, "hinge.v2.lambda": along * s + across * c,
                "hinge.v3.lambda": ROD_M * G + z,
                # Moments about the center: M_c + (-r e1) x (M g E3) = 0 -> M_c = -M g r e2, e2 = (-s, c, 0).
                "hinge.w1.lambda": ROD_M * G * r * s, "hinge.w2.lambda": -ROD_M * G * r * c}
    J = J_A**2 * 2 * A**2 * t1**3 / 3
    return Reference(values, HG_T, J, False, (t1, HG_T - t1))


PROBLEMS = {"bang_bang": (bang_bang_problem, bang_bang_reference),
            "clipped": (clipped_problem, clipped_reference),
            "hinge": (hinge_problem, hinge_reference)}


# -- true errors -------------------------------------------------------------------------------------------------
def sample_fractions(mesh, degrees, per_point: int = PER_POINT) -> np.ndarray:
    """``per_point`` times per collocation point, evenly in every interval, its ends included (fractions)."""
    return np.concatenate([np.linspace(a, b, per_point * d + 1) for a, b, d in zip(mesh[:-1], mesh[1:], degrees)])


def true_errors(sol, ref: Reference, mesh, degrees, windows=()) -> dict:
    """True errors per quantity as the estimate defines them (module notes), and where each is largest (s)."""
    names = {"states": sol.transcription.problem.model.coordinate_names + sol.transcription.problem.model.speed_names,
             "multipliers": [c for c in sol.sample_columns() if c.endswith(".lambda")],
             "inputs": list(sol.transcription.problem.model.inputs)}
    f = sample_fractions(mesh, degrees)
    t = f * sol.t_final
    # The reference at the same fraction of its own horizon (as the estimate compares a companion), from both
    # sides: where a jump falls on a sample (a mesh point at the switch), either side's value is the solution's.
    sides = [ref.values(np.clip(f * ref.t_final + e, 0.0, ref.t_final)) for e in (-1e-12, 1e-12)]
    inner = f > 0.0
    outside = inner.copy()
    for lo, hi in windows:
        outside &= (f < lo) | (f > hi)
    out = {}
    for q, labels in names.items():
        ours = np.array([sol.interpolate(n, t) for n in labels])
        left, right = (np.array([side[n] for n in labels]) for side in sides)
        scale = 1.0 if q == "states" else max(float(np.abs(left[:, inner]).max()), 1e-300)
        diff = np.minimum(np.abs(ours - left), np.abs(ours - right)).max(axis=0) / scale
        for key, mask in ((q, outside if q != "states" else np.ones_like(inner)), (f"{q}_all", inner)):
            if q == "states" and key.endswith("_all"):
                continue
            d = np.where(mask, diff, 0.0)
            out[key] = float(d.max())
            out[f"{key}_at"] = float(t[int(d.argmax())])
    out["t_final"] = abs(sol.t_final - ref.t_final)
    out["objective"] = abs(sol.objective - ref.objective) / abs(ref.objective)
    return out


# -- runs --------------------------------------------------------------------------------------------------------
def _warm_up(build) -> None:
    """One small untimed solve of a separate instance: CasADi's and IPOPT's first-use costs out of the timing."""
    build().solve(oc.Radau(4, degree=3), progress=False)


def _short_intervals(mesh: np.ndarray, T: float, k: int = 4) -> str:
    w = np.diff(mesh)
    order = np.argsort(w)[:k]
    return ", ".join(f"{mesh[i] * T:.5g}-{mesh[i + 1] * T:.5g}" for i in sorted(order))


def refined_run(name: str, tolerance: float) -> dict:
    """``problem.solve(tolerance=...)`` on holdout ``name``; the record, true errors and timings."""
    build, reference = PROBLEMS[name]
    ref = reference()
    _warm_up(build)
    problem = build()
    cpu, wall = time.process_time(), time.perf_counter()
    sol = problem.solve(tolerance=tolerance, progress=False)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    rec = sol.mesh_refinement
    mesh, degrees = np.array(rec["mesh"]), rec["degrees"]
    windows = [tuple(w) for w in rec.get("jump_windows", [])]
    hist = rec["history"]
    T = sol.t_final
    nearest = {s: float(np.abs(mesh * T - s).min()) for s in ref.switches}
    loads = sol.loads()
    # Diagnosis only (a library internal, read not changed): the switches the refinement located on the final
    # solution, as (kind, quantity, where (s), bracket (s), effect); the record keeps them only in part.
    from ocp_constraints.ocp.switch_detection import detect_switches
    located = [(w.kind, w.quantity, w.fraction * T, (w.bracket[0] * T, w.bracket[1] * T), w.effect)
               for w in detect_switches(sol)]
    normal = ("rail.v2.lambda", M * G) if "rail.v2.lambda" in loads else ("hinge.v3.lambda", ROD_M * G)
    return {"problem": name, "tolerance": tolerance, "met": bool(rec["met"]), "message": rec["message"],
            "refinements": rec["refinements"], "solves": int(sum(h.get("solves", 0) for h in hist)),
            "iterations": int(sum(h.get("iterations", 0) + h.get("companion_iterations", 0) for h in hist)),
            "per_mesh": [(h["points"], h.get("iterations", 0), h.get("companion_iterations"),
                          {q: h["estimate"].get(q) for q in ("states", "multipliers")}) for h in hist],
            "intervals": len(mesh) - 1, "points": hist[-1]["points"], "degrees": [min(degrees), max(degrees)],
            "widths": [float(np.diff(mesh).min() * T), float(np.diff(mesh).max() * T)],
            "short": _short_intervals(mesh, T), "switch_gap": nearest, "windows": windows,
            "estimate": dict(rec["estimate"]), "true": true_errors(sol, ref, mesh, degrees, windows),
            "normal_force_error": float(np.abs(loads[normal[0]] - normal[1]).max()),
            "t_final": T, "cpu": cpu, "wall": wall, "located": located}


def fixed_sweep(name: str, degrees=FIXED_DEGREES, intervals=FIXED_INTERVALS, cap: float = 30.0) -> list[dict]:
    """Uniform Radau meshes solved cold: true errors and CPU each; a degree stops after a solve over ``cap`` s."""
    build, reference = PROBLEMS[name]
    ref = reference()
    _warm_up(build)
    rows = []
    for d in degrees:
        for n in intervals:
            problem = build()
            cpu, wall = time.process_time(), time.perf_counter()
            try:
                sol = problem.solve(oc.Radau(n, degree=d), progress=False)
                status = sol.status
            except oc.OCPSolveError as exc:     # a failed fixed mesh: its row says so, no error measured
                rows.append({"degree": d, "intervals": n, "status": str(exc)[:80], "cpu": time.process_time() - cpu})
                continue
            cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
            mesh = np.linspace(0.0, 1.0, n + 1)
            rows.append({"degree": d, "intervals": n, "points": n * d + 1, "status": status, "cpu": cpu, "wall": wall,
                         "true": true_errors(sol, ref, mesh, [d] * n)})
            if cpu > cap:
                break
    return rows


def _child(target, args, queue, cpu_cap: float) -> None:
    resource.setrlimit(resource.RLIMIT_CPU, (int(cpu_cap), int(cpu_cap) + 5))
    try:
        queue.put(("ok", target(*args)))
    except Exception as exc:        # reported in the table, not hidden: the type and text
        queue.put(("error", f"{type(exc).__name__}: {str(exc)[:300]}"))


def in_child(target, args, cpu_cap: float):
    """``target(*args)`` in a fresh process under a CPU cap: ("ok", result), ("error", text) or ("cap", None)."""
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child, args=(target, args, queue, cpu_cap), daemon=True)
    proc.start()
    while True:
        try:
            return queue.get(timeout=5.0)
        except Exception:
            if not proc.is_alive():
                try:
                    return queue.get(timeout=1.0)
                except Exception:
                    return ("cap", None)
        finally:
            if not proc.is_alive():
                proc.join()


# -- table -------------------------------------------------------------------------------------------------------
def _ratio(true: float, est: float) -> str:
    if est == 0.0:
        return f"{true:.1e} / 0 (-)"
    return f"{true:.1e} / {est:.1e} ({true / est:.2f})"


def flags(row: dict) -> list[str]:
    """What breaks the contract: true > estimate or true < estimate / 10 (states, multipliers), met but not."""
    out = []
    est, tru, tol = row["estimate"], row["true"], row["tolerance"]
    for q in ("states", "multipliers"):
        if tru[q] > est[q]:
            out.append(f"{q}: true {tru[q]:.2e} > estimate {est[q]:.2e}")
        elif tru[q] < est[q] / 10:
            out.append(f"{q}: true {tru[q]:.2e} < estimate / 10 ({est[q]:.2e})")
    if row["met"] and max(tru["states"], tru["multipliers"]) > tol:
        out.append(f"met claimed, true errors states {tru['states']:.2e} multipliers {tru['multipliers']:.2e} > {tol:g}")
    return out


def cheapest(rows: list[dict], tol: float, free_time: bool, with_inputs: bool = True) -> dict | None:
    ok = [r for r in rows if "true" in r and r["true"]["states"] <= tol and r["true"]["multipliers_all"] <= tol
          and (not with_inputs or r["true"]["inputs_all"] <= tol) and (not free_time or r["true"]["t_final"] <= tol)]
    return min(ok, key=lambda r: r["cpu"]) if ok else None


def table(name: str, rows: list[dict], fixed: list[dict] | None, free_time: bool) -> str:
    lines = [f"### {name}", "",
             "| tolerance | met | refinements (solves), IPOPT iterations | final mesh | states true / estimate (ratio) "
             "| multipliers true / estimate (ratio) [all t > 0] | inputs true / estimate (ratio) [all t > 0] "
             "| final time true / estimate | objective rel. error | CPU / wall (s) | cheapest uniform Radau (CPU s) "
             "| refined / fixed CPU |", "|" + "---|" * 12]
    for row in rows:
        tol = row["tolerance"]
        if row.get("status") != "ok":
            lines.append(f"| {tol:g} | {row['status']} |" + " |" * 10)
            continue
        est, tru = row["estimate"], row["true"]
        mesh = (f"{row['intervals']} intervals, degrees {row['degrees'][0]}-{row['degrees'][1]}, {row['points']} points; "
                f"widths {row['widths'][0]:.2g}-{row['widths'][1]:.2g} s; shortest at {row['short']} s")
        if row["switch_gap"]:
            mesh += "; nearest mesh point to the switch(es): " + ", ".join(
                f"{g:.1e} s from {s:.4g}" for s, g in row["switch_gap"].items())
        if row["windows"]:
            mesh += "; jump windows (s, left out of the multipliers' and inputs' estimate): " + ", ".join(
                f"{lo * row['t_final']:.5g}-{hi * row['t_final']:.5g}" for lo, hi in row["windows"])
        tf = f"{tru['t_final']:.1e} / {est.get('t_final', 0.0):.1e}" if free_time else "-"
        best = cheapest(fixed, tol, free_time) if fixed else None
        best_sm = cheapest(fixed, tol, free_time, with_inputs=False) if fixed else None
        if fixed is None:
            fx, ratio = "(not run)", "-"
        else:
            fx = (f"radau{best['degree']} N={best['intervals']} ({best['points']} points): {best['cpu']:.2f}"
                  if best else "none in the sweep")
            if best_sm is not None and best_sm is not best:
                fx += (f"; on states and multipliers alone: radau{best_sm['degree']} N={best_sm['intervals']} "
                       f"({best_sm['points']} points): {best_sm['cpu']:.2f}")
            ratio = f"{row['cpu'] / best['cpu']:.1f}" if best else "-"
        met = ("yes" if row["met"] else "**no**") + f": {row['message'][:400]}"
        lines.append(
            f"| {tol:g} | {met} | {row['refinements']} ({row['solves']}), {row['iterations']} | {mesh} "
            f"| {_ratio(tru['states'], est['states'])} "
            f"| {_ratio(tru['multipliers'], est['multipliers'])} [{tru['multipliers_all']:.1e}] "
            f"| {_ratio(tru['inputs'], est['inputs'])} [{tru['inputs_all']:.1e}] | {tf} | {tru['objective']:.1e} "
            f"| {row['cpu']:.1f} / {row['wall']:.1f} | {fx} | {ratio} |")
    return "\n".join(lines)


def fixed_table(rows: list[dict], free_time: bool) -> str:
    lines = ["| uniform Radau | points | states | multipliers (all t > 0) | inputs (all t > 0) | final time | CPU / wall (s) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if "true" not in r:
            lines.append(f"| radau{r['degree']} N={r['intervals']} | | {r['status']} | | | | {r['cpu']:.2f} |")
            continue
        t = r["true"]
        lines.append(f"| radau{r['degree']} N={r['intervals']} | {r['points']} | {t['states']:.1e} | "
                     f"{t['multipliers_all']:.1e} | {t['inputs_all']:.1e} | "
                     f"{t['t_final']:.1e} | {r['cpu']:.2f} / {r['wall']:.2f} |" if free_time else
                     f"| radau{r['degree']} N={r['intervals']} | {r['points']} | {t['states']:.1e} | "
                     f"{t['multipliers_all']:.1e} | {t['inputs_all']:.1e} | - | {r['cpu']:.2f} / {r['wall']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tolerances", type=float, nargs="+", default=[1e-3, 1e-4, 1e-5, 1e-6])
    parser.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=list(PROBLEMS))
    parser.add_argument("--cpu-cap", type=float, default=120.0, help="CPU seconds per refined solve (RLIMIT_CPU)")
    parser.add_argument("--no-fixed", action="store_true", help="skip the uniform-mesh sweep")
    parser.add_argument("--out", type=Path, default=None, help="markdown file to write (default: print only)")
    args = parser.parse_args(argv)
    sections = [f"Command: `python scripts/refinement_holdouts.py --tolerances {' '.join(f'{t:g}' for t in args.tolerances)} "
                f"--problems {' '.join(args.problems)} --cpu-cap {args.cpu_cap:g}{' --no-fixed' if args.no_fixed else ''}`; "
                f"load average at start {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
                f"library {Path(oc.__file__).parent}."]
    for name in args.problems:
        ref = PROBLEMS[name][1]()
        rows = []
        for tol in args.tolerances:
            status, result = in_child(refined_run, (name, tol), args.cpu_cap)
            row = result if status == "ok" else {"tolerance": tol}
            row["status"] = status if status != "cap" else f"not finished within {args.cpu_cap:g} s CPU"
            if status == "error":
                row["status"] = f"error: {result}"
            rows.append(row)
            print(name, tol, row["status"], "" if status != "ok" else
                  f"met {row['met']} points {row['points']} est {row['estimate']} true "
                  f"{ {k: v for k, v in row['true'].items() if not k.endswith('_at')} } cpu {row['cpu']:.1f}", flush=True)
        fixed = None
        if not args.no_fixed:
            status, fixed = in_child(fixed_sweep, (name,), 20 * args.cpu_cap)
            if status != "ok":
                print(name, "fixed sweep:", status, fixed)
                fixed = None
        part = [table(name, rows, fixed, ref.free_time), ""]
        for row in rows:
            if row.get("status") == "ok":
                for f in flags(row):
                    part.append(f"- **flag** {name} at {row['tolerance']:g}: {f} "
                                f"(`python scripts/refinement_holdouts.py --problems {name} --tolerances {row['tolerance']:g} --no-fixed`)")
                tru = row["true"]
                part.append(f"- {name} at {row['tolerance']:g}: largest true errors at t = {tru['states_at']:.4g} s (states), "
                            f"{tru['multipliers_at']:.4g} s (multipliers), {tru['inputs_at']:.4g} s (inputs); "
                            f"normal load off M g by {row['normal_force_error']:.1e} N; per mesh (points, iterations, "
                            f"companion iterations, estimate states / multipliers): "
                            + "; ".join(f"{p}, {i}, {c}, {e['states']:.1e} / {e['multipliers']:.1e}"
                                        for p, i, c, e in row["per_mesh"])
                            + "; switches located on the final solution (kind, bound, at s, bracket s, effect): "
                            + ("; ".join(f"{k}, {q}, {a:.5g}, {b[0]:.5g}-{b[1]:.5g}, {e:.1e}" for k, q, a, b, e in row["located"])
                               or "none"))
        if fixed:
            part += ["", "Uniform meshes (cold):", "", fixed_table(fixed, ref.free_time)]
        sections.append("\n".join(part))
        print(part[0], flush=True)
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text("# Refinement holdouts (issue 19)\n\n" + "\n\n".join(sections) + "\n")


if __name__ == "__main__":
    main()
