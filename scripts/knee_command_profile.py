"""Where the whole ``knee`` command's time goes: cProfile of the CLI's ``main`` in this process.

    python scripts/knee_command_profile.py [--method collocation] [--sort cumulative|tottime] [--top 60]
        [--out /tmp/knee_command.prof] [--grep PATTERN ...]

Runs ``ocp-constraints knee $A --method M --out TMP`` (``$A``: the README's ngait_og5 arguments, as
``knee_collocation_command.py``) under :mod:`cProfile`, as the command runs it (OPENBLAS_NUM_THREADS=1 before
NumPy loads, MPLBACKEND=Agg), and prints the process's CPU and wall seconds and the profile's top functions.
cProfile slows Python-heavy code (not CasADi's / IPOPT's C++): read the shares, time with
``knee_collocation_command.py``. ``--grep``: print only the rows whose function matches one of the patterns.
"""
from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from knee_collocation_command import ARGS  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="collocation")
    ap.add_argument("--sort", default="cumulative")
    ap.add_argument("--top", type=int, default=60)
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "knee_command.prof")
    ap.add_argument("--grep", nargs="*", default=[])
    a = ap.parse_args()
    cpu, wall = time.process_time(), time.perf_counter()
    prof = cProfile.Profile()
    with tempfile.TemporaryDirectory() as tmp:
        prof.enable()
        from ocp_constraints.cli.main import main as cli_main

        code = cli_main(["knee", *ARGS, "--method", a.method, "--out", str(Path(tmp) / "out")])
        prof.disable()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    prof.dump_stats(a.out)
    print(f"exit {code}: {wall:.2f} s wall, {cpu:.2f} s CPU (this process, under cProfile); profile in {a.out}")
    buf = io.StringIO()
    stats = pstats.Stats(prof, stream=buf).sort_stats(a.sort)
    stats.print_stats(*([("|".join(a.grep))] if a.grep else []), a.top)
    print(buf.getvalue())


if __name__ == "__main__":
    main()
