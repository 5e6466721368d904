"""``report.html``: one self-contained page per run, checked as a file and in a real headless browser.

As a file: no script, no external resource; every ``<img>`` is one of the run's PNG files, byte for
byte (base64); the tables show the CSV's first rows (compared with NumPy's reading of the CSV) and
the summary's values. In a browser (Chromium or Chrome, headless, when one is installed; skipped with
the reason otherwise): the page renders to a screenshot in which the plots' lines are drawn
(matplotlib's first colour, #1f77b4, is present; the page's own style has no blue). Set
``OCP_REPORT_SCREENSHOTS=DIR`` to keep the screenshots.
"""
from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from ocp_constraints.cli.main import main

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.cells: list[str] = []
        self._in_cell = False

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        self._in_cell = tag in ("td", "th")

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self._in_cell = False

    def handle_data(self, data):
        if self._in_cell:
            self.cells.append(data)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    sim = tmp_path_factory.mktemp("sim")
    assert main(["simulate", "whirling", "--t-final", "2", "--out", str(sim), "--param", "omega_amplitude=0.5"]) == 0
    ocp = tmp_path_factory.mktemp("ocp")
    assert main(["solve", "pendulum", "--intervals", "12", "--out", str(ocp)]) == 0
    return {"simulation": sim, "ocp": ocp}


def _page(folder: Path) -> _Page:
    page = _Page()
    page.feed((folder / "report.html").read_text())
    return page


@pytest.mark.parametrize("kind", ["simulation", "ocp"])
def test_report_stands_alone_and_embeds_every_plot(runs, kind):
    folder = runs[kind]
    summary = json.loads((folder / "summary.json").read_text())
    page = _page(folder)
    assert not [t for t, _ in page.tags if t in ("script", "link", "iframe", "object")]
    images = [a["src"] for t, a in page.tags if t == "img"]
    assert all(src.startswith("data:image/png;base64,") for src in images)
    pngs = {p.read_bytes() for p in folder.glob("*.png")}
    assert len(images) == len(pngs) == len(summary["plots"]) > 0
    assert {base64.b64decode(src.split(",", 1)[1]) for src in images} == pngs
    hrefs = [a["href"] for t, a in page.tags if t == "a"]
    assert all((folder / h).is_file() for h in hrefs) and "summary.json" in hrefs
    assert str(summary["status"]) in page.cells


@pytest.mark.parametrize("kind", ["simulation", "ocp"])
def test_report_tables_show_the_first_rows_of_the_csv(runs, kind):
    folder = runs[kind]
    names = (folder / "loads.csv").read_text().splitlines()[0].split(",")
    data = np.loadtxt(folder / "loads.csv", delimiter=",", skiprows=1)[:10]
    cells = _page(folder).cells
    start = next(i for i in range(len(cells)) if cells[i: i + len(names)] == names)   # the loads.csv header
    shown = np.array([float(c) for c in cells[start + len(names): start + len(names) * 11]]).reshape(10, len(names))
    assert np.allclose(shown, data, rtol=5e-6, atol=1e-300)


def _browser() -> str | None:
    return next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None)


@pytest.mark.skipif(_browser() is None, reason=f"no headless browser found ({', '.join(BROWSERS)}); "
                                               "install one, e.g. apt-get install chromium")
@pytest.mark.parametrize("kind", ["simulation"])      # the OCP's page is the same template (checked as a file)
def test_report_renders_in_a_headless_browser(runs, kind, tmp_path):
    shot = tmp_path / f"{kind}.png"
    cmd = [_browser(), "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
           "--window-size=1200,3000", f"--screenshot={shot}", (runs[kind] / "report.html").as_uri()]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and shot.is_file(), proc.stderr[-2000:]
    import matplotlib.image

    pixels = (matplotlib.image.imread(shot)[:, :, :3] * 255).round()
    blue = np.all(np.abs(pixels - [31, 119, 180]) <= 2, axis=2)
    assert pixels.shape[:2] == (3000, 1200) and blue.sum() > 200      # the plots' lines are drawn
    keep = os.environ.get("OCP_REPORT_SCREENSHOTS")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, Path(keep) / f"report_{kind}.png")
