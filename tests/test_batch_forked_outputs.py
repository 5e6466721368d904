"""A run forked from a warm server writes what the same command writes as a fresh ``python -m``.

The fork server imports matplotlib before the first run that draws, and every run's child
inherits the server's modules; the outputs must not notice: the same files, the same bytes
(tables, OpenSim storage files, every figure), the same summary but for its clock readings.
"""
from __future__ import annotations

import json
import os

import pytest

from ocp_constraints.batch import launch

pytestmark = pytest.mark.skipif(os.name != "posix", reason="fork servers are POSIX")
CLOCKS = ("wall_time", "resources")   # seconds taken; memory free at the start


@pytest.fixture
def clean_env(monkeypatch):
    monkeypatch.delenv("MPLBACKEND", raising=False)
    launch.shutdown()
    yield
    launch.shutdown()


def test_a_forked_run_with_plots_writes_the_bytes_of_a_fresh_one(tmp_path, clean_env):
    folders = {}
    for warm in (True, False):
        out = tmp_path / ("warm" if warm else "fresh")
        done = launch.run_command(["simulate", "pendulum", "--t-final", "0.2", "--dt", "0.05", "--out", str(out)],
                                  str(tmp_path), str(tmp_path / "stdout.txt"), str(tmp_path / "stderr.txt"),
                                  str(tmp_path / "no-cancel"), warm)
        assert done.code == 0 and done.launch == ("warm" if warm else "fresh"), (tmp_path / "stderr.txt").read_text()
        folders[warm] = out
    names = sorted(p.name for p in folders[False].iterdir())
    assert sorted(p.name for p in folders[True].iterdir()) == names and "coordinates.png" in names
    for name in names:
        if name in ("summary.json", "report.html"):   # (they hold the run's own clock readings)
            continue
        assert (folders[True] / name).read_bytes() == (folders[False] / name).read_bytes(), name
    warm, fresh = (json.loads((folders[w] / "summary.json").read_text()) for w in (True, False))
    assert {k: v for k, v in warm.items() if k not in CLOCKS} == {k: v for k, v in fresh.items() if k not in CLOCKS}
