"""CPU seconds of the knee command's fixed costs outside the solve, before and after this session's changes.

    python scripts/knee_fixed_costs.py [--repeats 5]

CPU time (``time.process_time``), medians of ``--repeats`` fresh processes (each item in its own interpreter, so
that imports and caches are cold as in the command), because the machine's wall clock is shared:

- reading the trial's three .mat files (IK, GRF, KCF of ngait_og5) with ``scipy.io.loadmat``, its import
  included, NumPy's import subtracted (NumPy is loaded by the command anyway). A SciPy-free reader of these files
  (0.012 s) was written and removed again the same day: the project adds a well-kept library for a job, never a
  hand-written substitute for one, and SciPy is that library here;
- parsing the .osim model twice (inverse dynamics and muscle parameters, before) and once through
  :func:`~ocp_constraints.biomech.osim_model.model_xml` read twice (now), modules imported before the clock;
- drawing the knee figure (build, draw, PNG) on a new figure (before) and over one drawn ahead (now,
  :func:`~ocp_constraints.output.joint_plots.warm_knee_figure`), matplotlib loaded first in both.
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from knee_collocation_command import ARGS  # noqa: E402

FILES = [ARGS[ARGS.index(k) + 1] for k in ("--motion", "--grf", "--measured")]
MODEL = ARGS[ARGS.index("--model") + 1]
PRELUDE = "import os, time; os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); import numpy as np; c = time.process_time()\n"
ITEMS = {
    "read 3 .mat, scipy.io (before)": "import scipy.io\nfor f in FILES: scipy.io.loadmat(f, squeeze_me=True, struct_as_record=False)",
    "parse the .osim twice (before)": ("import xml.etree.ElementTree as ET\nc = time.process_time()\n"
                                       "for _ in range(2): ET.parse(MODEL).getroot()"),
    "model_xml twice (now)": ("from ocp_constraints.biomech.osim_model import model_xml\nc = time.process_time()\n"
                              "for _ in range(2): model_xml(MODEL)"),
}
FIGURE = """from ocp_constraints.output.plots import _load
_load()
import tempfile
from pathlib import Path
from ocp_constraints.output.joint_plots import warm_knee_figure, write_knee_figure
t = np.linspace(2.1775, 3.2833, 133)
loads = {"medial": np.sin(3 * t) + 1, "lateral": 0.5 * t, "total": np.sin(3 * t) + 1 + 0.5 * t}
tm = np.linspace(2.13, 3.3, 247)
args = (t, loads, "direct collocation, ideal muscles", (tm, {k: np.cos(tm) + 1 for k in loads}),
        [(2.1775, 2.85, "stance"), (2.85, 3.2833, "swing")])
if WARM:
    warm_knee_figure()
c = time.process_time()
write_knee_figure(Path(tempfile.mkdtemp()), *args)"""
ITEMS["knee figure on a new figure (before)"] = "WARM = False\n" + FIGURE
ITEMS["knee figure over a warm one (now)"] = "WARM = True\n" + FIGURE


def cpu(code: str) -> float:
    src = (f"FILES = {FILES!r}\nMODEL = {MODEL!r}\n" + PRELUDE + code + "\nprint(time.process_time() - c)")
    out = subprocess.run([sys.executable, "-c", src], check=True, capture_output=True, text=True,
                         env={**__import__("os").environ, "MPLBACKEND": "Agg"}).stdout
    return float(out.split()[-1])


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    for name, code in ITEMS.items():
        xs = [cpu(code) for _ in range(a.repeats)]
        print(f"{name:40s} median {statistics.median(xs):.3f} s CPU (least {min(xs):.3f}, {a.repeats} processes)",
              flush=True)
