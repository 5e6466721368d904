"""Results files of ``ocp-constraints gait``: summary.json, loads.csv and plots."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np



if TYPE_CHECKING:
    from .gait import GaitResult


def write_gait_results(result: GaitResult, out, side: str = "right", plots: bool = True, inputs: dict | None = None,
                       drawer=None) -> dict:
    """``summary.json``, ``loads.csv`` (DESIGN.md names plus ``<coordinate>_moment/_force``) and plots;
    ``drawer``: an :class:`~ocp_constraints.output.drawing_process.DrawingProcess` that draws them."""
    from ..output.files import software_versions, write_csv, write_json
    from ..output.report import write_report
    from ..output.sto import write_sto
    from ..output.run_folder import RunFolder

    run_folder = RunFolder(out)        # written whole: the previous run's files are replaced
    with run_folder.staged() as folder:
        leg = result.leg_joints(side)
        cols = {**result.generalized_force_columns(), **result.loads()}
        write_csv(folder / "loads.csv", result.t, cols)
        write_sto(folder / "loads.sto", result.t, cols)           # OpenSim storage files (inDegrees=no)
        write_sto(folder / "trajectory.sto", result.t, dict(zip(result.coordinate_names, result.states["p"].T)))
        summary = {
            "task": "gait inverse dynamics", "success": result.success, "status": result.status,
            "model": result.osim.path, "inputs": inputs or {},
            "side": side, "samples": len(result.t), "t_start": float(result.t[0]), "t_end": float(result.t[-1]),
            "filter": result.settings.get("filter"), "timing": result.settings.get("timing"),
            "angles": result.settings.get("angles"), "model_functions": result.settings.get("model"),
            "plates": result.plates, "feet": {s: l.foot for s, l in result.legs.items()},
            "leg_joints": {j: {"constraints": result.joints[j].constraints, "inputs": result.joints[j].inputs,
                               "parent": result.joints[j].parent, "child": result.joints[j].child} for j in leg},
            "n_constraints": len(result.constraint_names), "n_inputs": len(result.input_names),
            "max_equation_residual": float(result.residual.max()),
            "peak_generalized_forces": {c: float(np.max(np.abs(result.generalized_force(c))))
                                        for j in leg for c in result.osim.joints[j].coordinates},
            "wall_time": result.timings, "warnings": result.warnings, "software": software_versions(),
        }
        if plots:
            summary["plots"] = _plots(result, folder, leg, drawer)
            summary["report"] = "report.html"
        write_json(folder / "summary.json", summary)
        if plots:
            write_report(folder, summary, title=f"gait inverse dynamics ({side} leg)", plots=summary["plots"])
    return summary


def _plots(result: GaitResult, folder: Path, leg: list[str], drawer=None) -> list[str]:
    """``gait_<joint>.png`` per leg joint: generalized forces, constraint force, moment and power (drawn by
    ``drawer``, which has matplotlib loaded, if given)."""
    from ..output.joint_plots import write_gait_plots

    loads = result.loads()
    rows = []
    for j in leg:
        prefix = next((p for p in (f"{j}@{result.joints[j].child}", j) if f"{p}.F_x" in loads), None)
        rows.append((j, prefix, {c: result.generalized_force(c) for c in result.osim.joints[j].coordinates}))
    if drawer is not None:
        return drawer.call(write_gait_plots, folder, result.t, rows, loads)
    return write_gait_plots(folder, result.t, rows, loads)
