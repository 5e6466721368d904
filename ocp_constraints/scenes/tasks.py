"""Tasks on a scene that produce results on disk: ``run_simulation``.

This is the one place that strings model -> equations -> simulation -> results files
together, for the command line and for scripts alike.
"""
from __future__ import annotations

import time
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..mechanics.equations import SystemEquations
from ..errors import SceneError, SimulationError
from ..errors import OCPSolveError
from ..errors import interruption_reason
from ..output.files import software_versions, write_csv, write_json
from ..output.plots import write_plots
from ..output.report import write_report
from ..output.sto import write_sto
from ..output.run_folder import RunFolder
from .registry import Scene, build_scene
from ..dynamics.simulate import SimulationOptions, simulate
from ..dynamics.trajectory import Trajectory
from ..mechanics.state import consistent_state

if TYPE_CHECKING:   # annotations only: a simulation does not import the optimal-control code
    from ..ocp.problem import OptimalControlProblem
    from ..ocp.solution import OCPSolution

DRIFT_METHOD = (
    "acceleration-level constraints in a KKT system (sparse QR, no mass-matrix inversion), "
    "CVODES between output samples, projection onto the position- and velocity-level "
    "constraints every projection_interval"
)


def energy_balance(traj: Trajectory) -> dict[str, float | list]:
    """Energy E = T + U against the work of the constraint loads (eq. 27) and applied loads.

    ``relative_error`` is ``max |E(t) - E(0) - W(t)| / max(|E|, T)`` over the run.
    """
    T, U = traj.energy()   # one mapped call for all samples
    E = T + U
    W = traj.work.sum(axis=1) + traj.applied_work
    scale = max(float(np.abs(E).max()), float(T.max()), 1e-300)
    return {
        "initial": float(E[0]), "final": float(E[-1]),
        "constraint_work": float(traj.work[-1].sum()),
        "applied_work": float(traj.applied_work[-1]),
        "relative_error": float(np.abs(E - E[0] - W).max() / scale),
        "series": {"kinetic": T, "potential": U, "total": E, "work": W, "constraint_work": traj.work.sum(axis=1),
                   "applied_work": np.asarray(traj.applied_work, float)},
    }


def residuals(traj: Trajectory) -> tuple[float, float]:
    """``traj.residuals()`` (largest ``|phi|`` and ``|G u + e|``, drifts before projections included)
    with the constraint functions evaluated on all samples in one mapped call."""
    return traj.residuals()


def simulate_scene(scene: Scene | str | Path, t_final: float | None = None,
                   options: SimulationOptions | None = None) -> Trajectory:
    """Consistent initial state and forward simulation of ``scene`` (nothing written): a :class:`Scene`
    (:func:`~.registry.build_scene`, with its parameters), or a built-in scene's name or a scene file,
    built with its defaults."""
    if isinstance(scene, (str, Path)):
        scene = build_scene(str(scene))
    elif not isinstance(scene, Scene):
        raise SceneError(f"simulate_scene needs a Scene (oc.build_scene(name, overrides)) or a scene's name or file, "
                         f"got {type(scene).__name__}")
    eqs = SystemEquations(scene.model)
    w0 = scene.inputs(0.0) if scene.inputs else None
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates, inputs=w0)
    return simulate(eqs, q0, u0, float(scene.t_final if t_final is None else t_final), options, inputs=scene.inputs)


def run_simulation(scene: Scene, scene_name: str, t_final: float | None = None, out: str | Path | None = None,
                   options: SimulationOptions | None = None, plots: bool = True,
                   on_start=None) -> tuple[Trajectory, dict]:
    """Simulate ``scene`` and, if ``out`` is given, write the results files there (the folder
    written whole: :class:`~ocp_constraints.output.run_folder.RunFolder`).

    Returns the trajectory and the summary. If the simulation stops early, the part
    that was computed is written with ``"success": false`` and the error is re-raised; so is
    a run interrupted by SIGINT/SIGTERM (``"status": "interrupted by SIGINT"``; the
    ``KeyboardInterrupt`` is re-raised with ``written_to`` set to the folder). ``on_start``
    gets the run's estimate (samples, memory) when the integration starts.
    """
    opts = options or SimulationOptions()
    folder = RunFolder(out) if out is not None else None
    t_end = float(scene.t_final if t_final is None else t_final)
    clock = time.perf_counter()
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates, inputs=scene.inputs(0.0) if scene.inputs else None)
    built = time.perf_counter()
    error: BaseException | None = None
    estimate: dict = {}

    def started(info: dict) -> None:
        estimate.update(info)
        if on_start is not None:
            on_start(info)

    try:
        traj = simulate(eqs, q0, u0, t_end, opts, inputs=scene.inputs, on_start=started)
        status = "completed"
    except SimulationError as exc:
        if exc.partial is None or len(exc.partial) == 0:
            raise
        error, traj, status = exc, exc.partial, "stopped early"
    except KeyboardInterrupt as exc:   # SIGINT, or SIGTERM under the command line: write what exists
        partial = getattr(exc, "partial", None)
        if folder is None or partial is None or len(partial) == 0:
            raise
        error, traj, status = exc, partial, interruption_reason(exc)
    solved = time.perf_counter()
    pos, vel = residuals(traj)
    energy = energy_balance(traj)
    drift_q, drift_u = traj.max_drift
    summary = {
        "scene": scene_name,
        "task": "simulate",
        "success": error is None,
        "status": status,
        "message": "" if error is None else (status if isinstance(error, KeyboardInterrupt) else str(error))
        + (f" at t = {float(traj.t[-1]):g} s" if isinstance(error, KeyboardInterrupt) else ""),
        "parameters": scene.model.parameters,
        "solver": {"integrator": "cvodes", **asdict(opts), "t_final": t_end, "drift_handling": DRIFT_METHOD,
                   "last_step": estimate.get("last_step")},
        "resources": {"samples_planned": estimate.get("samples"), "memory_estimate_bytes": estimate.get("memory_bytes"),
                      "memory_available_bytes": estimate.get("available_bytes")},
        "iterations": None,
        "samples": len(traj),
        "t_reached": float(traj.t[-1]),
        "wall_time": {"build": built - clock, "solve": solved - built},
        "objective": None,
        "max_constraint_residual": {"position": pos, "velocity": vel},
        "max_residual_before_projection": {"position": drift_q, "velocity": drift_u},
        "energy": {k: v for k, v in energy.items() if k != "series"},
        "constraints": eqs.constraint_names,
        "joints": [ch.prefix for ch in eqs.load_channels],
        "software": software_versions(),
    }
    summary["wall_time"]["total"] = time.perf_counter() - clock
    if folder is not None:
        series = energy["series"]
        inputs = {n: traj.sample(n) for n in scene.model.inputs}
        write_trajectory_results(folder, traj, summary, inputs, plots,
                                 {"E": series["total"], "constraint_work": series["constraint_work"],
                                  "applied_work": series["applied_work"]})
        if isinstance(error, KeyboardInterrupt):
            error.written_to = str(folder.path)
    if error is not None:
        raise error
    return traj, summary


def write_trajectory_results(out: RunFolder | str | Path, traj: Trajectory, summary: dict, inputs: dict[str, np.ndarray],
                             plots: bool, energy: dict[str, np.ndarray] | None = None) -> list[str]:
    """trajectory.csv (states, then inputs), loads.csv, plots, and summary.json, written whole into
    ``out`` (a :class:`RunFolder` or a folder path): the previous run's files there are replaced,
    summary.json last (DESIGN.md). Returns the file names."""
    folder = out if isinstance(out, RunFolder) else RunFolder(out)
    with folder.staged() as staging:
        states = {**traj.state_columns(), **inputs}
        loads = traj.loads()
        write_csv(staging / "trajectory.csv", traj.t, states)
        write_csv(staging / "loads.csv", traj.t, loads)
        write_sto(staging / "trajectory.sto", traj.t, states)       # for OpenSim (inDegrees=no)
        write_sto(staging / "loads.sto", traj.t, loads)
        if plots:
            summary["plots"] = write_plots(staging, traj.t, states, loads, summary["joints"], energy,
                                           _drives(traj), list(inputs))
            summary["report"] = "report.html"
        write_json(staging / "summary.json", summary)
        if plots:
            write_report(staging, summary, plots=summary["plots"])
    return folder.committed


def _drives(traj) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Constraints with a prescribed rate (``e != 0``): multiplier and power ``-lambda e`` (eq. 27) per sample."""
    import casadi as ca

    eqs, t, q, _, lam, w = traj.mechanical_samples()
    driven = [k for k, c in enumerate(eqs.constraints) if not ca.SX(c.e).is_zero()]
    if not driven or not len(t):
        return {}
    e = np.asarray(ca.Function("e", [eqs.q, eqs.t, eqs.inputs], [eqs.e]).map(len(t))(
        np.asarray(q).T, np.asarray(t)[None, :], np.asarray(w).reshape(len(t), -1).T)).T
    return {eqs.constraint_names[k]: (lam[:, k], -lam[:, k] * e[:, k]) for k in driven}


def run_optimal_control(problem: OptimalControlProblem, scene_name: str, task: str, method,
                        out: str | Path | None = None, ipopt_options: dict | None = None,
                        plots: bool = True, reintegrate: bool = False, starts: int = 1,
                        seed: int = 0, tolerance: float | None = None,
                        max_refinements: int | None = None) -> tuple[OCPSolution, dict]:
    """Solve ``problem`` with the transcription ``method``; write results if ``out`` is given.

    ``summary`` carries the work of every joint load (e.g. a motor's energy) and, with
    ``reintegrate``, the deviation of a forward simulation of the optimal inputs; with
    ``starts`` > 1 (multi-start, :mod:`~ocp_constraints.ocp.multistart`, drawn with ``seed``) the
    best start is written and ``summary["multistart"]`` lists every start and the local optima.
    A failed solve writes the last iterate with ``"success": false`` and re-raises.
    ``tolerance``: hp mesh refinement from ``method`` until the estimated error meets it
    (:mod:`~ocp_constraints.ocp.mesh_refinement`); ``summary["mesh_refinement"]`` has the final
    mesh, the estimate per quantity and the history (at most ``max_refinements`` refinements), and
    ``summary["iterations"]`` counts every solve's IPOPT iterations (the last solve's alone:
    ``"iterations_last_solve"``).
    """
    folder = RunFolder(out) if out is not None else None
    error: OCPSolveError | None = None
    try:
        sol = problem.solve(method, ipopt_options, starts=starts, seed=seed, tolerance=tolerance,
                            max_refinements=max_refinements)
    except OCPSolveError as exc:
        if exc.solution is None:     # nothing to write (e.g. every multi-start task failed on its worker)
            raise
        error, sol = exc, exc.solution
    pos, vel = sol.residuals()
    eqs = problem.eqs
    summary = {
        "scene": scene_name,
        "task": task,
        "success": sol.success,
        "status": sol.status,
        "message": "" if error is None else str(error),
        "parameters": problem.model.parameters,
        "solver": {"nlp_solver": "ipopt", "transcription": method.label, "intervals": method.intervals,
                   "degree": getattr(method, "degree", None), "ipopt_options": ipopt_options or {},
                   "coordinates": problem.nlp_coordinates},
        "iterations": sol.iterations,
        "t_final": sol.t_final,
        "wall_time": {"build": sol.wall_time["transcription"] + sol.wall_time["solver_setup"], **sol.wall_time},
        "objective": sol.objective,
        "max_constraint_residual": {"position": pos, "velocity": vel},
        "joint_work": sol.joint_work(),
        "constraints": eqs.constraint_names,
        "joints": [ch.prefix for ch in eqs.load_channels],
        "inputs": list(problem.model.inputs),
        "software": software_versions(),
    }
    if getattr(sol, "mesh_refinement", None) is not None:     # tolerance: final mesh, estimate, history
        summary["mesh_refinement"] = sol.mesh_refinement
        history = sol.mesh_refinement["history"]
        summary.update(iterations=sum(h.get("iterations", 0) + h.get("companion_iterations", 0) for h in history),
                       iterations_last_solve=sol.iterations, solves=sum(h.get("solves", 0) for h in history))
        summary["solver"].update(transcription=sol.transcription.scheme.label, intervals=sol.transcription.scheme.intervals,
                                 degree=None)
    if getattr(sol, "multistart", None) is not None:      # starts > 1: every start and the local optima found
        summary["multistart"] = sol.multistart
    if reintegrate and error is None:
        check = sol.reintegrate()
        summary["reintegration"] = {k: v for k, v in check.items() if k != "trajectory"}
    if folder is not None:
        inputs = {n: sol.sample(n) for n in problem.model.inputs}
        write_trajectory_results(folder, sol.trajectory, summary, inputs, plots)
    if error is not None:
        raise error
    return sol, summary
