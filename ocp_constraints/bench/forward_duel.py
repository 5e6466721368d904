"""Forward simulation side by side with a peer (issue 14): interleaved runs, medians.

``pendulum``: Pinocchio's ABA + SciPy's DOP853 (:func:`.peers.pinocchio_pendulum`);
``sliding_disk``: sympy's ``LagrangesMethod`` + DOP853 (:func:`.peers.sympy_sliding_disk`).
Every setting runs ``runs`` times interleaved (ours at every tolerance, then the peer at
every tolerance, then ours again ...) so that the machine's load falls on both alike; the
medians are kept, of wall and of CPU time.

- In-process: ours builds the scene and its equations, finds the consistent start and
  simulates (loads included); the peer builds its model, integrates and computes its loads.
- Whole process: a fresh Python running the same, imports included (the peer's snippet
  imports only its own packages, not this one). Python's bytecode cache is on, as after a
  user's first run: ``PYTHONDONTWRITEBYTECODE`` (set in some sandboxes) is dropped for the
  child and ``PYTHONPYCACHEPREFIX`` points at a folder in the temporary directory.
- Error: the largest deviation from an independent reference (:mod:`.references`, DOP853 at
  SciPy's tightest ``rtol``, 2.3e-14) over the quantities *the peer reports*: its states,
  and its multipliers relative to the largest reference multiplier. Ours is measured on the
  same quantities (like with like: the peer's sliding disk has no angular velocities).
"""
from __future__ import annotations

import os
import statistics
import sys
import time

import numpy as np

from ..scenes.registry import load_scene_module

#: Our tolerances (rtol = atol): CVODES's global error is about 10-100x its rtol, so the
#: half-decades let the cheapest setting at a peer's error be found.
OURS = (1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)
THEIRS = (1e-6, 1e-8, 1e-10, 1e-12)

_OURS_SNIPPET = """
from ocp_constraints import SystemEquations, build_scene, consistent_state, simulate
from ocp_constraints.dynamics.simulate import SimulationOptions
s = build_scene({scene!r}); e = SystemEquations(s.model); q0, u0 = consistent_state(e, s.coordinates, s.rates)
simulate(e, q0, u0, {t_final!r}, SimulationOptions(rtol={tol!r}, atol={tol!r}, {settings}))
"""
_PEER_SNIPPET = """import math, time
import numpy as np
{source}
{fn}({t_final!r}, {tol!r}, {p!r})
"""   # the peer's own code only: no import of this package in the peer's whole-process time


def child_environment() -> dict[str, str]:
    """The environment of the timed child processes: bytecode cache on (see the module docstring)."""
    import tempfile

    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPYCACHEPREFIX"] = os.path.join(tempfile.gettempdir(), "ocp_constraints_pycache")
    return env


def run_child(argv: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """Wall and CPU seconds (user + system, of the child and its children) of one process."""
    import resource
    import subprocess

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True, env=env if env is not None else child_environment())
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _settings(compiled: str) -> dict:
    """SimulationOptions of a variant: ``"never"``/``"always"`` (maximal coordinates, compiled or not) or
    ``"joint"`` (joint coordinates, :mod:`~ocp_constraints.dynamics.joint_simulation`)."""
    return {"compiled": "never", "coordinates": "joint"} if compiled == "joint" else {"compiled": compiled}


def _ours_once(scene_name: str, t_final: float, tol: float, compiled: str):
    from ..dynamics.simulate import SimulationOptions, simulate
    from ..mechanics.equations import SystemEquations
    from ..mechanics.state import consistent_state
    from ..scenes.registry import build_scene

    wall, cpu = time.perf_counter(), time.process_time()
    scene = build_scene(scene_name)
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, t_final, SimulationOptions(rtol=tol, atol=tol, **_settings(compiled)))
    return time.perf_counter() - wall, time.process_time() - cpu, traj


def _peer(scene: str):
    from .peers import pinocchio_pendulum, sympy_sliding_disk

    return {"pendulum": pinocchio_pendulum, "sliding_disk": sympy_sliding_disk}[scene]


def forward_duel(scene: str = "pendulum", t_final: float = 10.0, runs: int = 3, ours=OURS, theirs=THEIRS,
                 compiled=("never", "always", "joint"), whole_process: bool = True, log=print) -> dict:
    """Our forward simulation against the scene's peer; see the module docstring. Returns the
    medians per setting and, per peer tolerance, our cheapest setting at equal or better error.
    ``compiled``: our variants, ``"never"``/``"always"`` (maximal coordinates) and ``"joint"`` (joint
    coordinates, left out for a scene they do not cover, e.g. the sliding disk's contact)."""
    import inspect

    from ..errors import ModelError

    from .references import TIGHTEST_RTOL, integrator_reference, pendulum_reference

    fn = _peer(scene)
    params = dict(load_scene_module(scene).DEFAULTS)
    if "joint" in compiled:
        try:
            _ours_once(scene, 0.05, 1e-8, "joint")
        except ModelError as exc:
            log(f"  {scene}: no joint-coordinate variant ({exc})")
            compiled = tuple(c for c in compiled if c != "joint")
    variants = [(tol, c) for tol in ours for c in compiled]
    env = child_environment()
    _ours_once(scene, 0.05, 1e-8, "always")      # compiled libraries built once (not timed: "after the first load")
    t = np.arange(0, t_final + 1e-9, 0.01)
    rf = pendulum_reference(params, t, TIGHTEST_RTOL) if scene == "pendulum" else integrator_reference(scene, t, rtol=TIGHTEST_RTOL)
    scale = max(float(np.abs(v).max()) for v in rf["lambda"].values())
    times: dict = {}
    errors: dict = {}
    keys: dict = {}

    def error_of(states, lams):
        st = max(float(np.abs(states[k] - rf["states"][k]).max()) for k in keys["states"])
        return max(st, max(float(np.abs(lams[k] - rf["lambda"][k]).max()) for k in keys["lambda"]) / scale)

    def timed(key, wall, cpu):
        times.setdefault(key + ("wall",), []).append(wall)
        times.setdefault(key + ("cpu",), []).append(cpu)

    peer_code = {tol: _PEER_SNIPPET.format(source=inspect.getsource(fn), fn=fn.__name__, t_final=t_final, tol=tol, p=params)
                 for tol in theirs}
    if whole_process:   # warm-up (bytecode written, files in the OS cache); not timed
        run_child([sys.executable, "-c", _OURS_SNIPPET.format(scene=scene, t_final=0.1, tol=1e-6,
                                                              settings="compiled='never'")], env)
        run_child([sys.executable, "-c", _PEER_SNIPPET.format(source=inspect.getsource(fn), fn=fn.__name__, t_final=0.1,
                                                              tol=theirs[0], p=params)], env)
    env_note = f"load average {os.getloadavg()[0]:.1f} at the start on {os.cpu_count()} cores"
    for rep in range(runs):
        for tol in theirs:
            started, cpu = time.perf_counter(), time.process_time()
            r = fn(t_final, tol, params)
            timed(("peer", tol, "", "in"), time.perf_counter() - started, time.process_time() - cpu)
            if rep == 0:
                keys.setdefault("states", [k for k in r["states"] if k in rf["states"]])
                keys.setdefault("lambda", list(r["lambda"]))
                errors[("peer", tol, "")] = error_of(r["states"], r["lambda"])
            if whole_process:
                timed(("peer", tol, "", "whole"), *run_child([sys.executable, "-c", peer_code[tol]], env))
        for tol, c in variants:
            wall, cpu, traj = _ours_once(scene, t_final, tol, c)
            timed(("ours", tol, c, "in"), wall, cpu)
            if rep == 0:
                cols = traj.sample_columns()
                errors[("ours", tol, c)] = error_of(cols, cols)
            if whole_process:
                code = _OURS_SNIPPET.format(scene=scene, t_final=t_final, tol=tol,
                                            settings=", ".join(f"{k}={v!r}" for k, v in _settings(c).items()))
                timed(("ours", tol, c, "whole"), *run_child([sys.executable, "-c", code], env))
        log(f"  {scene}: round {rep + 1}/{runs} done (load average {os.getloadavg()[0]:.1f})")
    med = {k: statistics.median(v) for k, v in times.items()}
    kinds = ("in", "whole") if whole_process else ("in",)
    rows = []
    for tol in theirs:
        target = errors[("peer", tol, "")]
        row = {"peer_rtol": tol, "peer_error": target}
        for kind in kinds:
            row[f"peer_{kind}"] = {"wall": med[("peer", tol, "", kind, "wall")], "cpu": med[("peer", tol, "", kind, "cpu")]}
            ok = [(med[("ours", o, c, kind, "wall")], o, c) for o, c in variants if errors[("ours", o, c)] <= target]
            best = min(ok) if ok else None
            if best is None:
                row[f"ours_{kind}"] = None
                continue
            w, o, c = best
            cpu = med[("ours", o, c, kind, "cpu")]
            row[f"ours_{kind}"] = {"rtol": o, "compiled": c, "error": errors[("ours", o, c)], "wall": w, "cpu": cpu,
                                   "ratio_wall": w / row[f"peer_{kind}"]["wall"], "ratio_cpu": cpu / row[f"peer_{kind}"]["cpu"]}
        rows.append(row)
    return {"scene": scene, "t_final": t_final, "runs": runs, "load": env_note, "rows": rows, "kinds": kinds,
            "error_on": keys["states"] + keys["lambda"], "reference": rf.get("method", "hand-written balance"),
            "ours": [{"rtol": o, "compiled": c, "error": errors[("ours", o, c)],
                      **{f"{kind}_{m}": med[("ours", o, c, kind, m)] for kind in kinds for m in ("wall", "cpu")}}
                     for o, c in variants],
            "peer": [{"rtol": o, "error": errors[("peer", o, "")],
                      **{f"{kind}_{m}": med[("peer", o, "", kind, m)] for kind in kinds for m in ("wall", "cpu")}}
                     for o in theirs]}


def duel_markdown(result: dict) -> str:
    """The tables of :func:`forward_duel`: per peer tolerance our cheapest setting at equal or better
    error and the time ratios (ours / theirs; below 1: ours faster), then every setting."""
    kinds = result["kinds"]
    head = (f"{result['scene']}, t = 0 ... {result['t_final']:g} s, medians of {result['runs']} interleaved runs "
            f"({result['load']}). Error: max deviation from the reference ({result['reference']}) "
            f"over {', '.join(result['error_on'])} (multipliers relative to the largest). Our settings: never / always "
            "(maximal coordinates, CasADi's virtual machine / compiled C), joint (joint coordinates).\n\n"
            "| peer rtol | peer error | " + " | ".join(f"peer {k} s (wall / CPU)" for k in kinds) + " | "
            + " | ".join(f"our cheapest {k} (rtol, setting: error)" for k in kinds) + " | "
            + " | ".join(f"ratio {k} (wall / CPU)" for k in kinds) + " |\n|" + "---|" * (2 + 3 * len(kinds)) + "\n")
    lines = []
    for r in result["rows"]:
        cells = [f"{r['peer_rtol']:g}", f"{r['peer_error']:.1e}"]
        cells += [f"{r[f'peer_{k}']['wall']:.4f} / {r[f'peer_{k}']['cpu']:.4f}" for k in kinds]
        for k in kinds:
            o = r[f"ours_{k}"]
            cells.append("none reaches it" if o is None else f"{o['rtol']:g}, {o['compiled']}: {o['error']:.1e}")
        for k in kinds:
            o = r[f"ours_{k}"]
            cells.append("-" if o is None else f"**{o['ratio_wall']:.2f}** / {o['ratio_cpu']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")

    def setting_rows(items, label):
        return "\n".join(f"| {label} | {o['rtol']:g} | {o.get('compiled', '')} | {o['error']:.1e} | "
                         + " | ".join(f"{o[f'{k}_wall']:.4f} / {o[f'{k}_cpu']:.4f}" for k in kinds) + " |" for o in items)

    every = ("\n\n| who | rtol | setting | error | " + " | ".join(f"{k} s (wall / CPU)" for k in kinds) + " |\n|"
             + "---|" * (4 + len(kinds)) + "\n" + setting_rows(result["peer"], "peer") + "\n"
             + setting_rows(result["ours"], "ours"))
    return head + "\n".join(lines) + every + "\n"


def main(argv: list[str] | None = None) -> None:
    """``python -m ocp_constraints.bench.forward_duel [scene] [runs] [out.md]``."""
    args = sys.argv[1:] if argv is None else argv
    res = forward_duel(args[0] if args else "pendulum", runs=int(args[1]) if len(args) > 1 else 3)
    text = duel_markdown(res)
    print(text)
    if len(args) > 2:
        with open(args[2], "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
