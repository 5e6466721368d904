"""Scaling and slow stress runs of ``ocp-constraints bench``.

Each scaling point runs in its own Python process, and its peak resident memory is read
from ``VmHWM`` in ``/proc/self/status`` (``ru_maxrss`` would not do: Linux carries it
over from the parent across fork and exec, so every point reported the bench's own peak):

- optimal control: the pendulum swing-up with Radau degree 3 at N = 25 ... 1,600;
- bodies: a chain of n = 1 ... 20 bodies on ball-and-socket joints (built with
  :class:`~ocp_constraints.mechanics.model.Model` and :func:`~ocp_constraints.mechanics.joints.ball_and_socket`,
  unit-quaternion rotations), simulated for 1 s.

Slow stress cases: 1,000 s of ``sliding_cylinder`` (against its exact motion) and of
``pendulum`` (energy balance), and ``whirling`` at Omega = 1e3 rad/s.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np

OCP_N = (25, 50, 100, 200, 400, 800, 1600)
CHAIN_N = (1, 2, 4, 8, 12, 16, 20)


def chain_model(n: int):
    """n slender bodies hanging in a chain from the origin, each on a ball-and-socket joint."""
    from ..mechanics import joints
    from ..mechanics.model import Model

    model = Model(f"chain{n}", gravity=(0.0, 0.0, -9.81))
    prev = None
    for i in range(n):
        b = model.add_body(f"b{i}", 1.0, np.diag([0.09, 0.09, 0.01]), rotation="quaternion")
        top = b.point("top", (0.0, 0.0, 0.3))
        joints.ball_and_socket(model, f"j{i}", top, prev)
        prev = b.point("bottom", (0.0, 0.0, -0.3))
    coords, rates = {}, {}
    tilt = 0.3  # every link rotated by tilt about E2: e3 = (sin tilt, 0, cos tilt); top = center + 0.3 e3
    e3 = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    for i in range(n):
        center = -0.6 * i * e3 - 0.3 * e3
        coords.update({f"b{i}.qw": np.cos(tilt / 2), f"b{i}.qx": 0.0, f"b{i}.qy": np.sin(tilt / 2), f"b{i}.qz": 0.0})
        coords.update({f"b{i}.x": center[0], f"b{i}.y": center[1], f"b{i}.z": center[2]})
        rates[f"b{i}.omega_z"] = 0.5
    return model, coords, rates


def _measure(kind: str, n: int) -> dict:
    if kind == "ocp":
        from ..scenes.registry import build_task
        from ..ocp.schemes import Radau

        _, problem = build_task("pendulum", "swing_up")
        sol = problem.solve(Radau(n, degree=3))
        w = sol.wall_time
        out = {"build_s": w["transcription"] + w["solver_setup"], "solve_s": w["solve"], "iterations": sol.iterations,
               "objective": sol.objective}
    else:
        from ..mechanics.equations import SystemEquations
        from ..dynamics.simulate import simulate
        from ..mechanics.state import consistent_state

        started = time.perf_counter()
        model, coords, rates = chain_model(n)
        eqs = SystemEquations(model)
        q0, u0 = consistent_state(eqs, coords, rates)
        built = time.perf_counter()
        traj = simulate(eqs, q0, u0, 1.0)
        out = {"build_s": built - started, "solve_s": time.perf_counter() - built, "residuals": traj.residuals(),
               "nq": eqs.nq, "nc": eqs.nc}
    out["peak_rss_mb"] = _peak_memory_mb()
    return out


def _peak_memory_mb() -> float:
    """High-water mark of this process's resident memory (MB), or NaN where /proc is missing."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def _fit(x, y) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def _run_point(kind: str, n: int) -> dict:
    res = subprocess.run([sys.executable, "-m", "ocp_constraints.bench.scaling", kind, str(n)], capture_output=True, text=True,
                         timeout=1800)
    if res.returncode:
        return {"error": res.stderr.strip().splitlines()[-1] if res.stderr.strip() else f"exit {res.returncode}"}
    return json.loads(res.stdout.strip().splitlines()[-1])


def run_scaling_and_stress(log=print) -> dict:
    points = {"ocp": {}, "chain": {}}
    for kind, grid in (("ocp", OCP_N), ("chain", CHAIN_N)):
        for n in grid:
            points[kind][n] = _run_point(kind, n)
            log(f"  {kind} n={n}: {points[kind][n]}")
    md = ["| what | n | build (s) | solve (s) | IPOPT iterations | peak memory (MB) |", "|---|---|---|---|---|---|"]
    fits = {}
    for kind, label in (("ocp", "swing-up Radau3, N intervals"), ("chain", "chain of n bodies, 1 s simulation")):
        good = {n: p for n, p in points[kind].items() if "error" not in p}
        for n, p in points[kind].items():
            if "error" in p:
                md.append(f"| {label} | {n} | failed: {p['error']} | | | |")
                continue
            iterations = p.get("iterations", "")
            md.append(f"| {label} | {n} | {p['build_s']:.3f} | {p['solve_s']:.3f} | {iterations} | {p['peak_rss_mb']:.0f} |")
            if iterations:
                p["solve_per_iteration_s"] = p["solve_s"] / iterations
        if len(good) >= 2:
            ns = np.array(sorted(good))
            quantities = ("build_s", "solve_s", "peak_rss_mb") + (("solve_per_iteration_s",) if kind == "ocp" else ())
            fits[kind] = {q: _fit(ns, [good[n][q] for n in ns]) for q in quantities}
    md.append("")
    for kind, f in fits.items():
        per_iteration = f", solve per IPOPT iteration {f['solve_per_iteration_s']:.2f}" if "solve_per_iteration_s" in f else ""
        md.append(f"Fitted exponents ({kind}, time ~ n^k over the whole range): build {f['build_s']:.2f}, solve {f['solve_s']:.2f}"
                  f"{per_iteration}, peak memory {f['peak_rss_mb']:.2f}.")
    stress = slow_stress(log)
    md += ["", "Slow stress cases:", ""] + [f"- {k}: {v}" for k, v in stress.items()]
    return {"points": points, "fits": fits, "stress": stress, "markdown": "\n".join(md)}


def slow_stress(log=print) -> dict:
    from .references import sliding_cylinder_reference
    from ..mechanics.equations import SystemEquations
    from ..scenes.registry import build_scene
    from ..dynamics.simulate import SimulationOptions, simulate
    from ..mechanics.state import consistent_state
    from ..scenes.tasks import energy_balance

    out = {}
    for name, T, over in (("sliding_cylinder", 1000.0, {}), ("pendulum", 1000.0, {}), ("whirling", 1.0, {"omega": 1000.0})):
        scene = build_scene(name, over)
        eqs = SystemEquations(scene.model)
        q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
        started = time.perf_counter()
        traj = simulate(eqs, q0, u0, T, SimulationOptions(dt=0.1 if T > 100 else 0.001))
        wall = time.perf_counter() - started
        pos, vel = traj.residuals()
        e = energy_balance(traj)["relative_error"]
        msg = f"{T:g} s in {wall:.1f} s; residuals position {pos:.1e}, velocity {vel:.1e}; energy balance error {e:.1e} (relative)"
        if name == "sliding_cylinder":
            ref = sliding_cylinder_reference(scene.model.parameters, traj.t)
            cols = traj.state_columns()
            err = max(float(np.abs(cols[k] - v).max()) for k, v in ref["states"].items())
            lam = traj.multiplier_columns()
            le = max(float(np.abs(lam[k] - v).max() / np.abs(v).max()) for k, v in ref["lambda"].items())
            msg += f"; max state error against the exact motion {err:.1e}, lambda error {le:.1e} (relative)"
        if name == "whirling":
            msg = f"Omega = {over['omega']:g} rad/s: " + msg + f"; max |lambda| {np.abs(traj.lam).max():.2e}"
        out[name] = msg
        log(f"  {name}: {msg}")
    return out


if __name__ == "__main__":
    print(json.dumps(_measure(sys.argv[1], int(sys.argv[2]))))
