"""The plots of a run, in one place: what a reader compares by eye is on one pair of axes.

* ``coordinates.png``: one panel per unit (positions in m, Euler angles in rad, quaternion
  parameters), never metres and radians on one axis; ``speeds.png`` likewise (m/s, rad/s);
  ``inputs.png`` the actuator inputs.
* ``loads_<joint>.png``: per joint load channel, the constraint force ``F_c`` (components and
  magnitude), the constraint moment ``M_c`` about the point it acts at, and its power
  ``P = F_c . v_C + M_c . omega`` (paper eqs. 26-27); gait and knee figures: :mod:`.joint_plots`.
* ``drive_<constraint>.png``: for a constraint with a prescribed rate (``e != 0``, e.g. the
  whirling body's motor ``g^1 . omega = Omega(t)``, sec. 3.4), its multiplier and its power
  ``-lambda e`` (eq. 27): the motor torque ``lambda_4`` and ``lambda_4 Omega``.
* ``energy.png``: ``E(t) - E(0)`` together with the work of the constraint loads and of the applied
  loads since ``t = 0`` and their sum, on the same axes (they coincide when energy balances), and
  the balance error ``E - E0 - W`` below.

Every figure is written whole (:func:`~ocp_constraints.output.files.write_atomic`).

Cost: a run pays for matplotlib only when it writes a plot, and then for its ``Figure`` and Agg
canvas alone (no pyplot, no GUI backend). Each figure is drawn once, by the save: the panels sit
at fixed margins in inches (:func:`new_figure`) instead of a ``tight_layout`` pass, which draws
the whole figure a second time to measure it. Figures of the same shape (the joints of a gait
trial, the load channels of a scene) reuse one figure (:func:`clear`): its axes and tick
artists, the most expensive part of a first draw, are made once.
"""
from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np

from .files import write_atomic

#: Units of the coordinate and speed columns, by the column name's last part.
GROUPS = [
    ("position", "position [m]", ("x", "y", "z")),
    ("angle", "Euler angle [rad]", ("psi", "theta", "phi")),
    ("quaternion", "quaternion parameter [-]", ("qw", "qx", "qy", "qz")),
]
SPEED_GROUPS = [
    ("velocity", "center-of-mass velocity [m/s]", ("vbar_x", "vbar_y", "vbar_z")),
    ("angular", "angular velocity, angle rates [rad/s]", ("omega_x", "omega_y", "omega_z", "psi_dot", "theta_dot", "phi_dot")),
]
#: Fixed margins [in]: left holds 7-character tick labels and the y label, top the title, bottom the
#: x tick labels and label, GAP the offset text ("1e-9") between panels that share their x axis.
LEFT, RIGHT, TOP, BOTTOM, GAP = 0.95, 0.2, 0.42, 0.55, 0.3
#: zlib level of the PNG files (0-9): see :func:`save`.
PNG_COMPRESSION = 1


def pyplot():
    """matplotlib's pyplot on the Agg backend (no display needed); for scripts. The library draws
    with :func:`new_figure`, which does not import pyplot."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def new_figure(width: float, height: float, rows: int = 1, height_ratios=None):
    """A figure of ``width`` x ``height`` inches on an Agg canvas, ``rows`` panels over one shared x axis
    at fixed margins (module docs), grid on. Returns ``(figure, [axes, ...])``."""
    _load()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    axes = list(fig.subplots(rows, 1, sharex=True, squeeze=False,
                             gridspec_kw={"height_ratios": height_ratios} if height_ratios else None)[:, 0])
    panel = (height - TOP - BOTTOM - GAP * (rows - 1)) / rows          # mean panel height [in]
    fig.subplots_adjust(left=LEFT / width, right=1 - RIGHT / width, top=1 - TOP / height, bottom=BOTTOM / height,
                        hspace=GAP / panel)
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig, axes


def clear(fig) -> None:
    """Empty a figure of :func:`new_figure` for the next one of its shape: lines, notes, shaded spans, legends,
    titles and labels go; axes, ticks and grid stay. Colours start again at C0 and the limits follow the new data."""
    from matplotlib import rcParams

    for ax in fig.axes:
        for artist in [*ax.lines, *ax.texts, *ax.patches]:     # patches: e.g. the knee figure's gait phases
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.set_prop_cycle(None)
        ax.set(title="", ylabel="", ylim=(0, 1))    # the limits of a new (empty) axes
        ax.title.set_fontsize(rcParams["axes.titlesize"])     # as a new axes's (a joint figure sizes its own)
        ax.relim()
        ax.set_autoscaley_on(True)


#: Figures drawn once ahead (:func:`keep_warm`), by (width, height, panels): the first figure of that shape
#: is drawn over one of them (:func:`clear`) instead of a new one.
_WARM: dict[tuple[float, float, int], object] = {}


def keep_warm(fig) -> None:
    """Keep ``fig``, a figure already drawn once, for the next figure of its shape (:func:`_figure`).

    A first draw makes the axes' tick artists, loads the fonts and fills the text caches (about 0.1 s of
    CPU more than drawing over a figure); a process that waits for its data (a
    :class:`~.drawing_process.DrawingProcess`) does that ahead."""
    width, height = (float(x) for x in fig.get_size_inches())
    _WARM[(width, height, len(fig.axes))] = fig


def draw_ahead(fig, dpi: int = 100) -> None:
    """Draw ``fig`` once as PNG in memory and keep it for the next figure of its shape (:func:`keep_warm`)."""
    import io

    fig.savefig(io.BytesIO(), format="png", dpi=dpi, pil_kwargs={"compress_level": PNG_COMPRESSION})
    keep_warm(fig)


def _figure(fig, width: float, height: float, rows: int):
    """``fig`` emptied for reuse when it has this size and number of equal panels, else a new figure."""
    if fig is None:
        fig = _WARM.pop((float(width), float(height), rows), None)
    if (fig is not None and len(fig.axes) == rows and tuple(fig.get_size_inches()) == (width, height)
            and len(set(fig.axes[0].get_subplotspec().get_gridspec().get_height_ratios())) == 1):
        clear(fig)
        return fig, list(fig.axes)
    return new_figure(width, height, rows)


def save(fig, out: Path, name: str, written: list[str], dpi: int = 110, close: bool = True) -> None:
    """Write ``fig`` as ``out/name`` (whole; one draw) and append the name to ``written``. ``close=False``
    keeps a figure to be reused (:func:`clear`)."""
    buf = io.BytesIO()
    # zlib level 1, not PIL's default 6: the same pixels, ~10% larger files, the encoding 0.05 -> 0.03 s
    # of CPU per 800 x 1020 figure (python scripts/plot_timing.py)
    fig.savefig(buf, format="png", dpi=dpi, pil_kwargs={"compress_level": PNG_COMPRESSION})
    if close and "matplotlib.pyplot" in sys.modules:     # a pyplot figure (a script's) leaves pyplot's list
        sys.modules["matplotlib.pyplot"].close(fig)
    write_atomic(Path(out) / name, buf.getvalue())
    written.append(name)


def file_name(label: str) -> str:
    """A file-name form of a joint or constraint name (``knee@tibia`` -> ``knee_at_tibia``)."""
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in label.replace("@", "_at_"))


def _lines(ax, t, series: dict[str, np.ndarray], **style) -> None:
    """One Line2D per series from a single plot call (one 2-D array)."""
    if series:
        ax.plot(t, np.column_stack([np.asarray(v, float) for v in series.values()]), label=list(series), **style)


def grouped_panels(t, columns: dict[str, np.ndarray], groups, title: str, fig=None):
    """One panel per unit group that has columns; None if none has. ``fig``: an earlier figure to draw
    over when it has the same panels (:func:`clear`)."""
    found = _groups_found(columns, groups)
    if not found:
        return None
    fig, axes = _figure(fig, 8, 2.6 + 2.2 * len(found), len(found))
    for ax, (label, cols) in zip(axes, found):
        _lines(ax, t, cols)
        ax.set(ylabel=label)
        ax.legend(fontsize=7, ncol=3 if len(cols) > 6 else 2, loc="best")
    axes[0].set_title(title)
    axes[-1].set(xlabel="t [s]")
    return fig


def energy_figure(t, energy: dict[str, np.ndarray]):
    """``E - E0`` and the work of the constraint and applied loads on one axis; the balance error below.

    ``energy``: ``E`` (J), ``constraint_work`` and ``applied_work`` (J, from ``t = 0``).
    """
    E = np.asarray(energy["E"], float)
    Wc = np.asarray(energy.get("constraint_work", np.zeros_like(E)), float)
    Wa = np.asarray(energy.get("applied_work", np.zeros_like(E)), float)
    W = Wc + Wa
    fig, (a1, a2) = new_figure(8, 6, 2, height_ratios=[3, 1.4])
    a1.plot(t, E - E[0], lw=2.5, label="E - E(0)  (E = T + U)")
    a1.plot(t, W, "k--", lw=1.4, label="W = work of constraint + applied loads")
    a1.plot(t, Wc, lw=1, label="work of the constraint loads (int -lambda e dt, eq. 27)")
    if np.any(Wa):
        a1.plot(t, Wa, lw=1, label="work of the applied loads (not gravity)")
    a1.set(ylabel="J", title="energy balance: E - E(0) = W")
    a1.legend(fontsize=8)
    a2.plot(t, E - E[0] - W, color="C3")
    a2.set(xlabel="t [s]", ylabel="E - E(0) - W [J]")
    return fig


def drive_figure(t, name: str, lam, power):
    """A driven constraint: its multiplier (the motor torque or force) and its power ``-lambda e`` (eq. 27)."""
    fig, (a1, a2) = new_figure(8, 5.5, 2)
    a1.plot(t, lam, color="C0")
    a1.set(ylabel=f"{name}.lambda [N m or N]", title=f"{name}: multiplier of a prescribed motion and its power")
    a2.plot(t, power, color="C1")
    a2.set(xlabel="t [s]", ylabel="power -lambda e [W]")
    return fig


def _vector_panel(ax, t, loads: dict, prefix: str, kind: str, ylabel: str) -> None:
    comps = [loads.get(f"{prefix}.{kind}_{a}") for a in "xyz"]
    if any(c is None for c in comps):
        return
    comps = np.column_stack([np.asarray(c, float) for c in comps])
    ax.plot(t, comps, lw=1.2, label=[f"{kind}_{a}" for a in "xyz"])
    ax.plot(t, np.sqrt((comps ** 2).sum(axis=1)), "k", lw=1.8, alpha=0.7, label=f"|{kind}|")
    ax.set(ylabel=ylabel)


def _peak(ax) -> float:
    """Largest |value| of the lines of ``ax`` (0 without lines)."""
    return max([float(np.abs(np.asarray(ln.get_ydata(), float)).max(initial=0.0)) for ln in ax.lines] or [0.0])


def joint_figure(t, loads: dict[str, np.ndarray], prefix: str, extra=None, title: str | None = None, fig=None):
    """``F_c`` at the joint's point, ``M_c`` about it (fixed basis) and the power ``P`` of one load channel.

    ``extra``: an optional ``(ylabel, {label: values})`` drawn in a first panel (e.g. the generalized
    forces of a gait joint's coordinates). ``fig``: an earlier joint figure saved with ``close=False``,
    drawn over when it has the same panels (:func:`clear`).
    """
    n = 3 + (extra is not None)
    fig, axes = _figure(fig, 8, 2.3 * n + 1.0, n)
    if extra is not None:
        ylabel, series = extra
        ax = axes.pop(0)
        _lines(ax, t, series)
        ax.set(ylabel=ylabel)
    _vector_panel(axes[0], t, loads, prefix, "F", "constraint force F_c [N]")
    _vector_panel(axes[1], t, loads, prefix, "M", "constraint moment M_c [N m]")
    power = loads.get(f"{prefix}.power")
    if power is not None:
        axes[2].plot(t, power, color="C3", label="P = F_c . v_C + M_c . omega")
    axes[2].set(xlabel="t [s]", ylabel="power P [W]")
    scale = max(1.0, _peak(axes[0]), _peak(axes[1]))
    for ax, what in zip(axes, ("F_c", "M_c", "P")):
        peak = _peak(ax)
        if ax.lines and peak < 1e-9 * scale:       # zero to round-off (e.g. a hinge's power, eq. 27): say so
            ax.set_ylim(-1, 1)
            note = f"{what} = 0" + ("" if peak == 0 else f" to round-off (largest |value| {peak:.1e})")
            ax.text(0.5, 0.75, note, transform=ax.transAxes, ha="center", va="center", fontsize=9, color="0.3",
                    bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8})
    for ax in fig.axes:
        if ax.lines:
            ax.legend(fontsize=7, ncol=4, loc="best")
    title = title or f"{prefix}: constraint load on the body at its point (fixed basis, eqs. 26-27)"
    fig.axes[0].set_title(title, fontsize=max(8.0, min(12.0, 12.0 * 72 / len(title))))
    return fig


def write_figures(out: Path, jobs: list[tuple[str, object]], dpi: int = 110) -> list[str]:
    """Draw and write ``(file name, draw)`` jobs, ``draw(previous figure or None) -> figure`` (a draw may
    reuse the previous figure, :func:`joint_figure`); returns the names in order. matplotlib is imported
    first, then the jobs are shared with a forked copy of this process when a second CPU is free
    (:func:`~ocp_constraints.output.forked.run_split`): the same files, drawn side by side."""
    from .forked import run_split

    _load()

    def work(part) -> None:
        fig = None
        for name, draw in part:
            fig = draw(fig)
            save(fig, out, name, [], dpi=dpi, close=False)

    run_split(list(jobs), work)
    return [name for name, _ in jobs]


def _load() -> None:
    """Import matplotlib's Figure and Agg canvas (before a fork, so that forked copies share them).

    On the first import, matplotlib writes the list of every Artist subclass's properties into the
    docstring of its ``set`` (``matplotlib.artist.kwdoc``, for ``help()`` only): 0.15-0.2 s of CPU, a
    third of the import. Unless matplotlib is loaded already, that list is left out of the docstrings
    of the classes imported here (a one-line pointer instead); nothing else changes."""
    if "matplotlib.figure" in sys.modules:
        return
    import matplotlib.artist as artist

    kwdoc = getattr(artist, "kwdoc", None)
    if callable(kwdoc):
        artist.kwdoc = lambda _: "Properties: see matplotlib.artist.kwdoc(<this class>)."
    try:
        import matplotlib.backends.backend_agg  # noqa: F401
        import matplotlib.figure  # noqa: F401
    finally:
        if callable(kwdoc):
            artist.kwdoc = kwdoc


def write_plots(out: Path, t: np.ndarray, states: dict[str, np.ndarray], loads: dict[str, np.ndarray],
                joints: list[str], energy: dict[str, np.ndarray] | None = None,
                drives: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
                inputs: list[str] | None = None) -> list[str]:
    """Every plot of a simulation or an optimal-control run (see module docs). Returns the file names.

    ``states``: trajectory.csv's columns (inputs among them, named in ``inputs``); ``loads``: loads.csv's;
    ``joints``: the load channels; ``energy``: see :func:`energy_figure`; ``drives``: constraint
    name -> (multiplier, power ``-lambda e``) at ``t``.
    """
    jobs: list[tuple[str, object]] = []
    for name, groups, title in (("coordinates.png", GROUPS, "coordinates"), ("speeds.png", SPEED_GROUPS, "speeds")):
        if _groups_found(states, groups):
            jobs.append((name, lambda prev, g=groups, s=title: grouped_panels(t, states, g, s, fig=prev)))
    if inputs:
        jobs.append(("inputs.png", lambda _: _inputs_figure(t, states, inputs)))
    for prefix in joints:           # drawn over one figure (same panels) in each process
        jobs.append((f"loads_{file_name(prefix)}.png", lambda prev, p=prefix: joint_figure(t, loads, p, fig=prev)))
    for name, (lam, power) in (drives or {}).items():
        jobs.append((f"drive_{file_name(name)}.png", lambda _, n=name, a=lam, b=power: drive_figure(t, n, a, b)))
    if energy:
        jobs.append(("energy.png", lambda _: energy_figure(t, energy)))
    return write_figures(out, jobs)


def _groups_found(columns: dict[str, np.ndarray], groups) -> list[tuple[str, dict[str, np.ndarray]]]:
    """``(axis label, {column: values})`` of each unit group that has columns (``body.x`` is in group ``x``)."""
    found = [(label, {k: v for k, v in columns.items() if "." in k and k.rsplit(".", 1)[1] in suffixes})
             for _, label, suffixes in groups]
    return [(label, cols) for label, cols in found if cols]


def _inputs_figure(t, states: dict[str, np.ndarray], inputs: list[str]):
    fig, (ax,) = new_figure(8, 4)
    _lines(ax, t, {n: states[n] for n in inputs})
    ax.set(xlabel="t [s]", ylabel="input [N m or N]", title="actuator inputs")
    ax.legend(fontsize=7, ncol=2)
    return fig
