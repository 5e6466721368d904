"""The knee figure drawn by a forked process that loaded matplotlib while the run computed, and the
parent drawing it itself when that process is gone. The figure's size in pixels is its figsize
(8 x 8.5 in) times 100 dpi."""
import numpy as np


def _png_size(path) -> tuple[int, int]:
    head = open(path, "rb").read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def _figure_args():
    t = np.linspace(0.0, 1.0, 11)
    loads = {"medial": np.sin(3 * t) + 1, "lateral": 0.5 * t, "total": np.sin(3 * t) + 1 + 0.5 * t}
    return t, loads, "test", None, [(0.0, 0.6, "stance"), (0.6, 1.0, "swing")]


def test_figure_process_writes_the_knee_figure_at_its_size(tmp_path):
    from ocp_constraints.biomech.knee_figure_process import FigureProcess

    fp = FigureProcess()
    name = fp.draw(tmp_path, _figure_args())
    if name is None and fp.error == "fork is not available":
        return                                          # drawn in the parent instead (next test)
    assert name == "knee_contact.png", fp.error
    assert _png_size(tmp_path / name) == (800, 850)     # figsize (8, 8.5) in at 100 dpi


def test_a_dead_figure_process_leaves_the_figure_to_the_parent(tmp_path):
    from ocp_constraints.biomech.knee_figure_process import FigureProcess
    from ocp_constraints.biomech.knee_pipeline import _plot

    t, loads, *_ = _figure_args()
    res = type("R", (), {"t": t, "medial": loads["medial"], "lateral": loads["lateral"], "total": loads["total"]})
    fp = FigureProcess()
    fp.close()                                          # the child is gone before the figure is asked for
    assert _plot(dict(result=res, bw=1.0), tmp_path, fp) == "knee_contact.png"
    assert fp.error is not None
    assert _png_size(tmp_path / "knee_contact.png") == (800, 850)
