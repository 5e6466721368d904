"""Biomechanics figures: gait joints (generalized forces with the joint's constraint force, moment and
power, :func:`~ocp_constraints.output.plots.joint_figure`); the knee's contact loads, predicted and
measured, over the gait phases.

Arrays in, figures out (matplotlib's Agg canvas, no pyplot; see :mod:`.plots` for what keeps them cheap):
the biomechanics and the tasks compute, this module draws.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .plots import _figure, file_name, joint_figure, write_figures


def write_gait_plots(out: Path, t, joints: list[tuple[str, str | None, dict[str, np.ndarray]]],
                     loads: dict[str, np.ndarray]) -> list[str]:
    """``gait_<joint>.png`` per leg joint: ``(joint, load channel or None, {coordinate label: generalized force})``."""
    jobs = [(f"gait_{file_name(joint)}.png",          # drawn over one figure (same panels) in each process
             lambda prev, j=joint, p=prefix, g=generalized: joint_figure(
                 t, loads, p or j, ("generalized force [N m or N]", g),
                 title=f"{j}: generalized forces; constraint load on the child at its point", fig=prev))
            for joint, prefix, generalized in joints]
    return write_figures(out, jobs, dpi=100)


def warm_gait_figure(dpi: int = 100) -> None:
    """Draw a gait joint figure (four panels, :func:`write_gait_plots`) once over made-up data, in memory, and
    keep it for the first real one (:func:`~.plots.keep_warm`): run by a drawing process while it waits."""
    from .plots import draw_ahead

    t = np.linspace(0.0, 1.0, 50)
    loads = {f"warm.{k}_{a}": np.sin((i + 1) * t) for i, (k, a) in enumerate((k, a) for k in "FM" for a in "xyz")}
    loads["warm.power"] = t
    draw_ahead(joint_figure(t, loads, "warm", ("generalized force [N m or N]", {"q": t, "r": -t}), title="warm"), dpi)


def knee_figure(t, predicted: dict[str, np.ndarray], label: str, measured=None, phases=()):
    """Medial, lateral and total contact force (body weights): predicted, measured (``(t, {name: values})``)
    and the gait phases shaded (``[(t0, t1, "stance" or "swing"), ...]``)."""
    fig, axes = _figure(None, 8, 8.5, 3)      # over a figure drawn ahead (warm_knee_figure) if there is one
    colors = {"stance": "#d9e8f5", "swing": "#fbe6cf"}
    for ax, (name, y) in zip(axes, predicted.items()):
        for a, b, phase in phases:
            ax.axvspan(a, b, color=colors.get(phase, "#eeeeee"), zorder=0, lw=0)
        ax.plot(t, y, color="C0", lw=2, label=f"predicted ({label})")
        if measured is not None:
            tm, cols = measured
            keep = (tm >= t[0]) & (tm <= t[-1])
            ax.plot(tm[keep], cols[name][keep], "k--", lw=1.5, label="measured (eTibia)")
        ax.set(ylabel=f"{name} contact force [BW]")
    handles, labels = axes[0].get_legend_handles_labels()
    import matplotlib.patches as mpatches

    for phase in dict.fromkeys(p for _, _, p in phases):
        handles.append(mpatches.Patch(color=colors.get(phase, "#eeeeee"), label=phase))
        labels.append(phase)
    axes[0].legend(handles, labels, fontsize=8, loc="upper right")
    axes[0].set_title("knee contact forces over the gait cycle")
    axes[-1].set(xlabel="t [s]")
    return fig


def warm_knee_figure(dpi: int = 100) -> None:
    """Draw a knee figure (:func:`knee_figure`: spans, measured curves, legend) once over made-up data, in memory,
    and keep it for the real one (:func:`~.plots.keep_warm`; 0.2 -> 0.13 s of CPU for the first figure): run by
    the knee command's drawing process while the run computes."""
    from .plots import draw_ahead

    t = np.linspace(0.0, 1.0, 50)
    loads = {"medial": t, "lateral": 1 - t, "total": 1 + 0 * t}
    draw_ahead(knee_figure(t, loads, "warm", (t, loads), [(0.0, 0.6, "stance"), (0.6, 1.0, "swing")]), dpi)


def write_knee_figure(out: Path, t, predicted: dict[str, np.ndarray], label: str, measured=None, phases=()) -> str:
    """``out/knee_contact.png`` from :func:`knee_figure`; its file name. A module-level function, so a
    :class:`~.drawing_process.DrawingProcess` can run it in its child."""
    from .plots import save

    written: list[str] = []
    save(knee_figure(t, predicted, label, measured, phases), Path(out), "knee_contact.png", written, dpi=100)
    return written[0]
