"""Does a mesh point *at* an input's junction lift the ~1e-5 floor of "Kinks inside an interval"? (issue 19)

    python scripts/junction_at_mesh_point.py [--tolerances 1e-4 1e-5 1e-6 1e-7]

The torque-limited rod of ``examples/torque_limited_rod.py`` (no gravity, I psi'' = tau, |tau| <= 0.9 N m, least
effort): Pontryagin's torque is sat(c (T/2 - t)), on its bound until t1 and after T - t1, t1 found here by bisection
on a 200,001-point quadrature of psi(T) = 1.2 rad (independent of the library). Each tolerance is solved twice: from
the default first mesh (junctions wherever the refinement's meshes put them) and from a first mesh with points at the
exact junctions t1 and T - t1 added to the default 10 intervals of degree 5 (the best a located junction time could
do). Printed: met, points, CPU, the estimate and the true error over 8,000 times (states: angle, rate, centre of mass's velocity; multipliers:
the hinge force relative to its largest; inputs: the torque relative to its bound), whether the arcs were imposed
(``mesh_refinement["input_arcs"]``, :mod:`ocp_constraints.ocp.junction_times`).
"""
from __future__ import annotations

import argparse
import runpy
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

import ocp_constraints as oc

M, L, T, THETA, U = 0.8, 0.6, 0.8, 1.2, 0.9       # kg, m, s, rad, N m
I_HINGE = M * L**2 / 3


def final_angle(t1: float) -> float:
    """psi(T) for the torque U until t1, then linear to 0 at T/2, antisymmetric after."""
    ts = np.linspace(0.0, T / 2, 200_001)
    tau = np.where(ts < t1, U, U * (T / 2 - ts) / (T / 2 - t1))
    omega = np.concatenate([[0.0], np.cumsum((tau[1:] + tau[:-1]) / 2 * np.diff(ts))]) / I_HINGE
    return 2.0 * float(np.sum((omega[1:] + omega[:-1]) / 2 * np.diff(ts)))


T1 = brentq(lambda t: final_angle(t) - THETA, 1e-6, T / 2 - 1e-6, xtol=1e-14)


def torque(t: np.ndarray) -> np.ndarray:
    s = np.where(t <= T / 2, t, T - t)
    return np.where(t <= T / 2, 1.0, -1.0) * np.where(s < T1, U, U * (T / 2 - s) / (T / 2 - T1))


_GRID = np.linspace(0.0, T, 400_001)
_RATE = np.concatenate([[0.0], np.cumsum((torque(_GRID)[1:] + torque(_GRID)[:-1]) / 2 * np.diff(_GRID))]) / I_HINGE
_ANGLE = np.concatenate([[0.0], np.cumsum((_RATE[1:] + _RATE[:-1]) / 2 * np.diff(_GRID))])


def true_errors(sol, times: np.ndarray) -> dict:
    """Against the closed form: the angle, its rate and the centre of mass's velocity (rad, rad/s, m/s), the torque (of its bound) and the hinge force (of its
    largest; the hinge holds the centre of mass on its circle of radius L/2: |F| = m L/2 sqrt(psi''^2 + psi'^4))."""
    rate, angle = np.interp(times, _GRID, _RATE), np.interp(times, _GRID, _ANGLE)
    force = M * L / 2 * np.hypot(torque(times) / I_HINGE, rate**2)
    got = np.hypot(sol.interpolate("hinge.v1.lambda", times), sol.interpolate("hinge.v2.lambda", times))
    # the centre of mass, L/2 from the hinge: velocity (L/2) psi' (cos psi, sin psi)
    exact = {"rod.psi": angle, "rod.omega_z": rate, "rod.vbar_x": L / 2 * rate * np.cos(angle),
             "rod.vbar_y": L / 2 * rate * np.sin(angle)}
    return {"states": max(float(np.abs(sol.interpolate(name, times) - value).max()) for name, value in exact.items()),
            "torque": float(np.abs(sol.interpolate("motor", times) - torque(times)).max()) / U,
            "hinge force": float(np.abs(got - force).max() / force.max())}


def _junction_offset(arcs: list[dict]) -> float:
    """The largest distance (s) of the imposed arcs' inner ends from the closed form's junctions t1 and T - t1."""
    ends = [x for a in arcs for x in (a["start"], a["end"]) if 0.0 < x < T]
    return max(min(abs(x - T1), abs(x - (T - T1))) for x in ends)


def problem() -> oc.OptimalControlProblem:
    """A fresh copy of ``examples/torque_limited_rod.py``'s problem (the example's solve runs only as a script)."""
    return runpy.run_path(str(Path(__file__).resolve().parents[1] / "examples" / "torque_limited_rod.py"))["problem"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerances", type=float, nargs="+", default=[1e-4, 1e-5, 1e-6, 1e-7])
    args = ap.parse_args(argv)
    mesh = sorted(set(np.linspace(0.0, 1.0, 11).round(15)) | {T1 / T, 1.0 - T1 / T})
    starts = {"default first mesh": None,
              "mesh points at the exact junctions": oc.Radau(mesh=tuple(mesh), degrees=(5,) * (len(mesh) - 1))}
    print(f"junctions at t1 = {T1:.12f} s and T - t1 (closed form)")
    times = np.linspace(0.0, T, 8001)[1:]
    for tol in args.tolerances:
        for label, method in starts.items():
            cpu = time.process_time()
            sol = problem().solve(method, tolerance=tol)
            cpu = time.process_time() - cpu
            mr = sol.mesh_refinement
            true, est = true_errors(sol, times), mr["estimate"]
            print(f"{tol:g}, {label}: met {mr['met']}, {sol.transcription.scheme.point_count} points, {cpu:.1f} s CPU; "
                  f"estimate / true: states {est['states']:.1e} / {true['states']:.1e}, multipliers {est['multipliers']:.1e} "
                  f"/ {true['hinge force']:.1e} (hinge force), inputs {est['inputs']:.1e} / {true['torque']:.1e}; "
                  + (f"arcs imposed, junctions {_junction_offset(mr['input_arcs']):.1e} s from the closed form's"
                     if mr.get("input_arcs") else "arcs not imposed"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
