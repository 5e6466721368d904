"""``ocp-constraints gait``: results files (summary.json, loads.csv, plots) and the command line."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np



if TYPE_CHECKING:
    from .gait import GaitResult


def write_gait_results(result: GaitResult, out, side: str = "right", plots: bool = True, inputs: dict | None = None) -> dict:
    """``summary.json``, ``loads.csv`` (DESIGN.md names plus ``<coordinate>_moment/_force``) and plots."""
    from ..output.files import software_versions, write_csv, write_json
    from ..output.run_folder import RunFolder

    run_folder = RunFolder(out)        # written whole: the previous run's files are replaced
    folder = run_folder.begin()
    leg = result.leg_joints(side)
    cols = {**result.generalized_force_columns(), **result.loads()}
    write_csv(folder / "loads.csv", result.t, cols)
    summary = {
        "task": "gait inverse dynamics", "success": result.success, "status": result.status,
        "model": result.osim.path, "inputs": inputs or {},
        "side": side, "samples": len(result.t), "t_start": float(result.t[0]), "t_end": float(result.t[-1]),
        "filter": result.settings.get("filter"), "timing": result.settings.get("timing"),
        "angles": result.settings.get("angles"),
        "plates": result.plates, "feet": {s: l.foot for s, l in result.legs.items()},
        "leg_joints": {j: {"constraints": result.joints[j].constraints, "inputs": result.joints[j].inputs,
                           "parent": result.joints[j].parent, "child": result.joints[j].child} for j in leg},
        "n_constraints": len(result.eqs.constraint_names), "n_inputs": len(result.model.inputs),
        "max_equation_residual": float(result.residual.max()),
        "peak_generalized_forces": {c: float(np.max(np.abs(result.generalized_force(c))))
                                    for j in leg for c in result.osim.joints[j].coordinates},
        "wall_time": result.timings, "warnings": result.warnings, "software": software_versions(),
    }
    if plots:
        summary["plots"] = _plots(result, folder, leg)
    write_json(folder / "summary.json", summary)
    run_folder.commit()
    return summary


def _plots(result: GaitResult, folder: Path, leg: list[str]) -> list[str]:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..output.files import write_atomic

    written = []
    for j in leg:
        coords = result.osim.joints[j].coordinates
        fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
        for c in coords:
            axes[0].plot(result.t, result.generalized_force(c), label=c)
        axes[0].set(ylabel="generalized force [N m or N]", title=f"{j}: generalized forces, load on the child at its point")
        loads = result.loads()
        prefix = next((p for p in (f"{j}@{result.joints[j].child}", j) if f"{p}.F_x" in loads), None)
        if prefix:
            for a in "xyz":
                axes[1].plot(result.t, loads[f"{prefix}.F_{a}"], label=f"F_{a}")
                axes[2].plot(result.t, loads[f"{prefix}.M_{a}"], label=f"M_{a}")
        axes[1].set(ylabel="constraint force [N]")
        axes[2].set(xlabel="t [s]", ylabel="constraint moment [N m]")
        for ax in axes:
            ax.grid(alpha=0.3)
            if ax.lines:
                ax.legend(fontsize=7)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100)
        plt.close(fig)
        write_atomic(folder / f"gait_{j}.png", buf.getvalue())
        written.append(f"gait_{j}.png")
    return written
