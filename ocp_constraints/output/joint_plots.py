"""Joint figures: a joint's constraint force, moment and power; gait joints with their generalized
forces; the knee's contact loads, predicted and measured, over the gait phases.

Arrays in, figures out (matplotlib, Agg): the biomechanics and the tasks compute, this module draws.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .plots import file_name, pyplot, save


def _vector_panel(ax, t, loads: dict, prefix: str, kind: str, ylabel: str) -> None:
    comps = [loads.get(f"{prefix}.{kind}_{a}") for a in "xyz"]
    if any(c is None for c in comps):
        return
    for a, c in zip("xyz", comps):
        ax.plot(t, c, lw=1.2, label=f"{kind}_{a}")
    ax.plot(t, np.sqrt(sum(np.asarray(c, float) ** 2 for c in comps)), "k", lw=1.8, alpha=0.7, label=f"|{kind}|")
    ax.set(ylabel=ylabel)


def joint_figure(t, loads: dict[str, np.ndarray], prefix: str, extra=None, title: str | None = None):
    """``F_c`` at the joint's point, ``M_c`` about it (fixed basis) and the power ``P`` of one load channel.

    ``extra``: an optional ``(ylabel, {label: values})`` drawn in a first panel (e.g. the generalized
    forces of a gait joint's coordinates).
    """
    plt = pyplot()
    n = 3 + (extra is not None)
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.3 * n + 1.0), sharex=True)
    axes = list(axes)
    if extra is not None:
        ylabel, series = extra
        ax = axes.pop(0)
        for k, v in series.items():
            ax.plot(t, v, label=k)
        ax.set(ylabel=ylabel)
    _vector_panel(axes[0], t, loads, prefix, "F", "constraint force F_c [N]")
    _vector_panel(axes[1], t, loads, prefix, "M", "constraint moment M_c [N m]")
    power = loads.get(f"{prefix}.power")
    if power is not None:
        axes[2].plot(t, power, color="C3", label="P = F_c . v_C + M_c . omega")
    axes[2].set(xlabel="t [s]", ylabel="power P [W]")
    scale = max([1.0] + [float(np.abs(np.asarray(ln.get_ydata(), float)).max(initial=0.0))
                         for ax in axes[:2] for ln in ax.lines])
    for ax, what in zip(axes, ("F_c", "M_c", "P")):
        peak = max([float(np.abs(np.asarray(ln.get_ydata(), float)).max(initial=0.0)) for ln in ax.lines] or [0.0])
        if ax.lines and peak < 1e-9 * scale:       # zero to round-off (e.g. a hinge's power, eq. 27): say so
            ax.set_ylim(-1, 1)
            ax.text(0.5, 0.5, f"{what} = 0 to round-off (largest |value| {peak:.1e})", transform=ax.transAxes,
                    ha="center", va="center", fontsize=9, color="0.3")
    for ax in fig.axes:
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=7, ncol=4, loc="best")
    fig.axes[0].set_title(title or f"joint {prefix}: load on the body at its point (fixed basis), eqs. 26-27")
    fig.tight_layout()
    return fig


def write_gait_plots(out: Path, t, joints: list[tuple[str, str | None, dict[str, np.ndarray]]],
                     loads: dict[str, np.ndarray]) -> list[str]:
    """``gait_<joint>.png`` per leg joint: ``(joint, load channel or None, {coordinate label: generalized force})``."""
    written: list[str] = []
    for joint, prefix, generalized in joints:
        fig = joint_figure(t, loads, prefix or joint, ("generalized force [N m or N]", generalized),
                           title=f"{joint}: generalized forces; constraint load on the child at its point")
        save(fig, out, f"gait_{file_name(joint)}.png", written, dpi=100)
    return written


def knee_figure(t, predicted: dict[str, np.ndarray], label: str, measured=None, phases=()):
    """Medial, lateral and total contact force (body weights): predicted, measured (``(t, {name: values})``)
    and the gait phases shaded (``[(t0, t1, "stance" or "swing"), ...]``)."""
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
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
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    import matplotlib.patches as mpatches

    for phase in dict.fromkeys(p for _, _, p in phases):
        handles.append(mpatches.Patch(color=colors.get(phase, "#eeeeee"), label=phase))
        labels.append(phase)
    axes[0].legend(handles, labels, fontsize=8, loc="upper right")
    axes[0].set_title("knee contact forces over the gait cycle")
    axes[-1].set(xlabel="t [s]")
    fig.tight_layout()
    return fig
