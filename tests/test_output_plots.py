"""The run plots (output/plots.py, output/joint_plots.py): what each panel shows, that a figure drawn over
(reused for the next joint) gives the same PNG bytes as a new figure of the same data, and that drawing
needs neither pyplot nor, before a plot is written, matplotlib at all."""
from __future__ import annotations

import io
import subprocess
import sys

import numpy as np


def _loads(t, prefix: str, scale: float, zero_power: bool = False) -> dict[str, np.ndarray]:
    out = {}
    for i, a in enumerate("xyz"):
        out[f"{prefix}.F_{a}"] = scale * np.sin((i + 1) * t)
        out[f"{prefix}.M_{a}"] = 0.1 * scale * np.cos((i + 2) * t)
    out[f"{prefix}.power"] = np.zeros_like(t) if zero_power else scale * t * np.sin(t)
    return out


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=30)
    return buf.getvalue()


def _pixels(png: bytes) -> tuple:
    """Size, mode and pixel bytes of a PNG, whatever its compression."""
    from PIL import Image

    im = Image.open(io.BytesIO(png))
    return im.size, im.mode, im.tobytes()


def test_a_joint_figure_shows_force_components_their_magnitude_moment_and_power():
    from ocp_constraints.output.plots import joint_figure

    t = np.linspace(0.0, 2.0, 21)
    loads = _loads(t, "hip@femur", 300.0)
    fig = joint_figure(t, loads, "hip@femur", ("generalized force [N m or N]", {"hip_flexion": t ** 2, "hip_adduction": -t}))
    gen, force, moment, power = fig.axes
    assert [ln.get_label() for ln in gen.lines] == ["hip_flexion", "hip_adduction"]
    assert [ln.get_label() for ln in force.lines] == ["F_x", "F_y", "F_z", "|F|"]
    assert [ln.get_label() for ln in moment.lines] == ["M_x", "M_y", "M_z", "|M|"]
    assert [ax.get_ylabel() for ax in fig.axes] == ["generalized force [N m or N]", "constraint force F_c [N]",
                                                    "constraint moment M_c [N m]", "power P [W]"]
    assert power.get_xlabel() == "t [s]" and all(ax.get_legend() is not None for ax in fig.axes)
    # |F| against the components summed by hand (not through the plotting code's own array)
    by_hand = [np.hypot(np.hypot(300 * np.sin(t[k]), 300 * np.sin(2 * t[k])), 300 * np.sin(3 * t[k])) for k in range(t.size)]
    assert np.allclose(force.lines[3].get_ydata(), by_hand, rtol=1e-14)
    assert np.array_equal(gen.lines[0].get_ydata(), t ** 2)
    from matplotlib.colors import to_hex

    assert [to_hex(c.get_color()) for c in force.lines[:3]] == ["#1f77b4", "#ff7f0e", "#2ca02c"]   # C0, C1, C2


def test_a_figure_drawn_over_is_the_same_png_as_a_new_one():
    """Reuse must not carry anything over: limits, colours, legends and the zero note follow the new data."""
    from ocp_constraints.output.plots import joint_figure

    t = np.linspace(0.0, 1.0, 15)
    cases = [("knee", _loads(t, "knee", 800.0), {"knee_angle": 40 * np.sin(3 * t)}),
             ("hinge", _loads(t, "hinge", 2.0, zero_power=True), {"a": t, "b": -t, "c": t ** 3}),
             ("ankle", _loads(t, "ankle", 5e4), {"ankle_angle": -t})]
    fig = None
    for prefix, loads, gen in cases:
        fig = joint_figure(t, loads, prefix, ("generalized force [N m or N]", gen), title=prefix, fig=fig)
        reused = _png(fig)
        fresh = joint_figure(t, loads, prefix, ("generalized force [N m or N]", gen), title=prefix)
        assert fresh is not fig and reused == _png(fresh), prefix
        assert len(fig.axes) == 4 and len(fig.axes[0].lines) == len(gen)
        notes = [x.get_text() for x in fig.axes[3].texts]
        assert notes == (["P = 0"] if prefix == "hinge" else []), prefix          # the zero panel says so, once
    # the speeds drawn over the coordinates (two panels each; the joint figure's title size does not stay)
    from ocp_constraints.output.plots import GROUPS, SPEED_GROUPS, grouped_panels

    columns = {"b.x": t, "b.z": -t, "b.psi": t ** 2, "b.vbar_x": 3 * t, "b.omega_y": np.cos(t), "b.psi_dot": 2 * t}
    fig = grouped_panels(t, columns, GROUPS, "coordinates")
    _png(fig)
    fig = grouped_panels(t, columns, SPEED_GROUPS, "speeds", fig=fig)
    assert _png(fig) == _png(grouped_panels(t, columns, SPEED_GROUPS, "speeds"))


def test_write_plots_names_every_figure_at_its_size(tmp_path, monkeypatch):
    """Also drawn in two processes where two CPUs are usable (output/forked.py): a load figure drawn by the
    forked child is the same bytes as one drawn here."""
    from ocp_constraints.output.plots import joint_figure, write_plots

    t = np.linspace(0.0, 1.0, 11)
    states = {"body.x": t, "body.y": -t, "body.psi": 0.1 * t, "body.vbar_x": np.ones_like(t), "body.omega_z": t, "u": t}
    loads = {**_loads(t, "j1", 3.0), **_loads(t, "j2", 4.0)}
    energy = {"E": 1 + 1e-9 * t, "constraint_work": 1e-9 * t}
    monkeypatch.setenv("OCP_OUTPUT_PROCESSES", "2")
    names = write_plots(tmp_path, t, states, loads, ["j1", "j2"], energy, {"drive": (t, -t)}, ["u"])
    assert names == ["coordinates.png", "speeds.png", "inputs.png", "loads_j1.png", "loads_j2.png", "drive_drive.png",
                     "energy.png"]
    sizes = {}
    for name in names:
        head = (tmp_path / name).read_bytes()[:24]
        assert head[:8] == b"\x89PNG\r\n\x1a\n"
        sizes[name] = (int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big"))
    # figsize in inches times 110 dpi: coordinates two panels (8 x 7.0), a load figure three (8 x 7.9)
    assert sizes["coordinates.png"] == (880, 770) and sizes["loads_j1.png"] == sizes["loads_j2.png"] == (880, 869)
    assert sizes["energy.png"] == (880, 660) and sizes["inputs.png"] == (880, 440)
    buf = io.BytesIO()
    joint_figure(t, loads, "j1").savefig(buf, format="png", dpi=110)      # jobs 1, 3, 5 go to the child
    assert _pixels((tmp_path / "loads_j1.png").read_bytes()) == _pixels(buf.getvalue())   # the files' zlib level differs


def test_work_a_forked_process_could_not_do_is_done_by_the_parent(tmp_path):
    import os

    from ocp_constraints.output.forked import run_split

    parent = os.getpid()

    def work(part):
        for i in part:
            if os.getpid() != parent:
                raise RuntimeError("a child that fails before its first item")
            (tmp_path / f"{i}.txt").write_text(str(os.getpid()))

    run_split(list(range(6)), work, k=3)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"{i}.txt" for i in range(6)]
    assert {p.read_text() for p in tmp_path.iterdir()} == {str(parent)}


def test_no_fork_with_other_threads_running_or_no_idle_cpu(monkeypatch):
    import os
    import threading

    from ocp_constraints.output import forked
    from ocp_constraints.output.forked import processes

    monkeypatch.delenv("OCP_OUTPUT_PROCESSES", raising=False)
    # The load rule alone first: an earlier test on this xdist worker may have left a thread behind
    # (a Dask client's, a timer's), which would make processes() answer 1 for the thread rule instead.
    monkeypatch.setattr(forked.threading, "active_count", lambda: 1)
    monkeypatch.setattr(forked, "_load", lambda: 2.0)            # both cores of a 2-core machine busy
    assert processes(10) == 1
    monkeypatch.setattr(forked, "_load", lambda: 0.3)
    assert processes(10) == min(2, len(os.sched_getaffinity(0)))
    assert processes(3) == 1                                      # fewer than two items each

    monkeypatch.undo()                                            # the real thread count from here on
    monkeypatch.setenv("OCP_OUTPUT_PROCESSES", "2")
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        assert processes(10) == 1
    finally:
        stop.set()
        thread.join()
    monkeypatch.setenv("OCP_OUTPUT_PROCESSES", "1")
    assert processes(10) == 1


def test_plots_import_matplotlib_only_to_draw_and_never_pyplot(tmp_path):
    code = ("import sys, numpy as np\n"
            "from ocp_constraints.output import plots, joint_plots, report\n"
            "assert not [m for m in sys.modules if m.startswith('matplotlib')], 'matplotlib imported early'\n"
            "t = np.linspace(0, 1, 5)\n"
            "l = {f'j.{k}_{a}': t for k in 'FM' for a in 'xyz'}\n"
            f"joint_plots.write_gait_plots({str(tmp_path)!r}, t, [('j', None, {{'q': t}})], l)\n"
            "assert 'matplotlib.figure' in sys.modules and 'matplotlib.pyplot' not in sys.modules\n"
            # the docstrings' property lists were skipped during our import only: matplotlib's own function is
            # back, and set() still takes every property (it is built from the setters, not the docstring)
            "import matplotlib.artist as A, matplotlib.lines as L\n"
            "assert A.kwdoc.__module__ == 'matplotlib.artist' and 'Properties:' in A.kwdoc(L.Line2D)\n"
            "ln = L.Line2D([0, 1], [0, 1]); ln.set(linewidth=3, color='r', zorder=5)\n"
            "assert (ln.get_linewidth(), ln.get_color(), ln.get_zorder()) == (3, 'r', 5)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / "gait_j.png").is_file()


def test_a_drawing_process_runs_the_call_and_the_parent_does_when_it_is_gone(monkeypatch):
    import os

    import pytest

    from ocp_constraints.output.drawing_process import DrawingProcess

    monkeypatch.setenv("OCP_OUTPUT_PROCESSES", "2")
    dp = DrawingProcess()
    if dp.error is not None:
        pytest.skip(f"no drawing process here: {dp.error}")
    assert dp.call(os.getpid) != os.getpid()             # ran in the child
    gone = DrawingProcess()
    gone.close()                                          # the child ended before the call
    assert gone.call(os.getpid) == os.getpid() and gone.error is not None


def test_the_first_gait_figure_after_a_warm_up_is_the_same_png_as_a_new_one(monkeypatch):
    """A drawing process draws one figure ahead (joint_plots.warm_gait_figure); the first real figure is drawn
    over it and must carry nothing of the made-up data."""
    from ocp_constraints.output import plots
    from ocp_constraints.output.joint_plots import warm_gait_figure
    from ocp_constraints.output.plots import joint_figure

    monkeypatch.setattr(plots, "_WARM", {})
    warm_gait_figure()
    (warm,) = plots._WARM.values()
    t = np.linspace(0.4, 1.6, 13)
    loads = _loads(t, "knee", 700.0)
    args = (t, loads, "knee", ("generalized force [N m or N]", {"knee_angle_r": 30 * np.sin(4 * t)}))
    first = joint_figure(*args, title="knee_r")
    assert first is warm and not plots._WARM
    assert _png(first) == _png(joint_figure(*args, title="knee_r"))


def test_a_drawing_process_ended_by_the_parent_dies_of_sigterm_and_runs_no_python(monkeypatch):
    """The command line's SIGTERM handler raises RunInterrupted; a forked drawing child inherited it, so the
    parent's terminate() of a child on its way out printed a raw 'Process ocp-drawing:' traceback. The child
    must die of the signal itself (exit code -SIGTERM), whatever the parent's handler is."""
    import signal

    import pytest

    from ocp_constraints.output.drawing_process import DrawingProcess
    from ocp_constraints.output.signals import interrupt_on_signals

    monkeypatch.setenv("OCP_OUTPUT_PROCESSES", "2")
    with interrupt_on_signals():
        dp = DrawingProcess()
        if dp.error is not None:
            pytest.skip(f"no drawing process here: {dp.error}")
        proc = dp._proc
        dp.close()                                        # terminate() while the child waits for a call
    assert proc.exitcode == -signal.SIGTERM
