"""The knee figure drawn by the drawing process (a forked child that loaded matplotlib while the run
computed, where a core is idle), and by the parent itself when that process is gone: the same file.
The figure's size in pixels is its figsize (8 x 8.5 in) times 100 dpi."""
import numpy as np


def _png_size(path) -> tuple[int, int]:
    head = open(path, "rb").read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def _figure_args():
    t = np.linspace(0.0, 1.0, 11)
    loads = {"medial": np.sin(3 * t) + 1, "lateral": 0.5 * t, "total": np.sin(3 * t) + 1 + 0.5 * t}
    return t, loads, "test", None, [(0.0, 0.6, "stance"), (0.6, 1.0, "swing")]


def test_drawing_process_writes_the_knee_figure_at_its_size(tmp_path):
    from ocp_constraints.output.drawing_process import DrawingProcess
    from ocp_constraints.output.joint_plots import write_knee_figure

    name = DrawingProcess().call(write_knee_figure, tmp_path, *_figure_args())
    assert name == "knee_contact.png"
    assert _png_size(tmp_path / name) == (800, 850)     # figsize (8, 8.5) in at 100 dpi


def test_a_dead_drawing_process_leaves_the_knee_figure_to_the_parent(tmp_path):
    from ocp_constraints.biomech.knee_pipeline import _plot
    from ocp_constraints.output.drawing_process import DrawingProcess

    t, loads, *_ = _figure_args()
    res = type("R", (), {"t": t, "medial": loads["medial"], "lateral": loads["lateral"], "total": loads["total"]})
    fp = DrawingProcess()
    fp.close()                                          # the child is gone before the figure is asked for
    assert _plot(dict(result=res, bw=1.0), tmp_path, fp) == "knee_contact.png"
    assert fp.error is not None
    assert _png_size(tmp_path / "knee_contact.png") == (800, 850)


def _forced_drawing_process(monkeypatch):
    """A DrawingProcess with its child whatever the load (OCP_OUTPUT_PROCESSES=2); skip where none can be forked."""
    import pytest

    from ocp_constraints.output.drawing_process import DrawingProcess

    monkeypatch.setenv("OCP_OUTPUT_PROCESSES", "2")
    fp = DrawingProcess()
    if fp._proc is None:
        pytest.skip(f"no drawing process here: {fp.error}")
    return fp


def test_a_submitted_figure_is_drawn_by_the_child_while_the_parent_works(tmp_path, monkeypatch):
    """submit() returns at once; result() gives the child's file, the same bytes as drawn in this process."""
    from ocp_constraints.output.joint_plots import write_knee_figure

    fp = _forced_drawing_process(monkeypatch)
    (tmp_path / "child").mkdir()
    (tmp_path / "here").mkdir()
    try:
        fp.submit(write_knee_figure, tmp_path / "child", *_figure_args())
        assert write_knee_figure(tmp_path / "here", *_figure_args()) == "knee_contact.png"   # the parent's work
        assert fp.result() == "knee_contact.png"
    finally:
        fp.close()
    assert fp.error is None                              # drawn by the child, not redrawn here
    assert (tmp_path / "child" / "knee_contact.png").read_bytes() == (tmp_path / "here" / "knee_contact.png").read_bytes()


def test_a_child_that_dies_after_submit_leaves_the_figure_to_the_parent(tmp_path, monkeypatch):
    from ocp_constraints.output.joint_plots import write_knee_figure

    fp = _forced_drawing_process(monkeypatch)
    proc = fp._proc
    fp.submit(write_knee_figure, tmp_path, *_figure_args())
    proc.kill()                                          # e.g. killed by the OOM killer while drawing
    proc.join(5.0)
    assert fp.result() == "knee_contact.png"
    assert fp.error is not None
    assert _png_size(tmp_path / "knee_contact.png") == (800, 850)


def test_the_first_knee_figure_after_a_warm_up_is_the_same_png_as_a_new_one(tmp_path, monkeypatch):
    """The drawing process draws a knee figure ahead (warm_knee_figure); the real one is drawn over it and
    must carry nothing of the made-up data (spans, curves, legend): the same bytes as on a new figure."""
    from ocp_constraints.output import plots
    from ocp_constraints.output.joint_plots import warm_knee_figure, write_knee_figure

    monkeypatch.setattr(plots, "_WARM", {})
    t, loads, label, _, phases = _figure_args()
    measured = (np.linspace(-0.1, 1.1, 30), {k: np.cos(np.linspace(-0.1, 1.1, 30)) + i for i, k in enumerate(loads)})
    args = (t, loads, label, measured, [(0.0, 0.3, "stance"), (0.3, 1.0, "swing")])
    (tmp_path / "new").mkdir()
    (tmp_path / "warm").mkdir()
    write_knee_figure(tmp_path / "new", *args)
    warm_knee_figure()
    assert len(plots._WARM) == 1
    write_knee_figure(tmp_path / "warm", *args)
    assert not plots._WARM                                # the warm figure was used
    assert (tmp_path / "warm" / "knee_contact.png").read_bytes() == (tmp_path / "new" / "knee_contact.png").read_bytes()
