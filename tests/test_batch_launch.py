"""How a batch run is started (:mod:`ocp_constraints.batch.launch`), warm (forked) and fresh, without Dask.

Each run is ``python -m ocp_constraints simulate PROBE.py``: the scene file is executed when
it loads, so it can report what its process sees (folder, ``sys.path[0]``, session, the
environment), burn CPU by its own clock, touch memory, crash or hang. Checked against those
independent values: the run is a process of its own in its folder; its CPU time and peak
memory as recorded; a cancel stops the run and what it forked; a crashed run leaves the warm
server usable.
"""
from __future__ import annotations

import json
import os
import signal
import threading
import time

import psutil
import pytest

from ocp_constraints.batch import launch

pytestmark = pytest.mark.skipif(os.name != "posix", reason="process groups and fork are POSIX")

PROBE = """
import json, os, sys, time
print(json.dumps({"cwd": os.getcwd(), "path0": sys.path[0], "pid": os.getpid(), "sid": os.getsid(0),
                  "mpl": os.environ.get("MPLBACKEND"), "omp": os.environ.get("OMP_NUM_THREADS")}), flush=True)
while time.process_time() < 0.3:   # CPU time of this process, by its own clock
    pass
block = b"x" * (120 * 2**20)       # 120 MB, every page written
import resource
own = resource.getrusage(resource.RUSAGE_SELF)   # this process's CPU by the kernel, as it sees itself
print(json.dumps({"cpu": own.ru_utime + own.ru_stime}), flush=True)
raise RuntimeError("probe done")
"""
HANG = """
import os, time
child = os.fork()
if child == 0:
    os.execvp("sleep", ["sleep", "120"])
open("grandchild.pid", "w").write(str(child))
time.sleep(120)
"""


@pytest.fixture(scope="module", autouse=True)
def own_servers():
    """This module's fork servers start here (one is reused by its tests) and close at its end."""
    launch.shutdown()
    with pytest.MonkeyPatch.context() as mp:
        for name in ("MPLBACKEND", "OMP_NUM_THREADS"):
            mp.delenv(name, raising=False)   # the run's defaults apply
        yield
        launch.shutdown()


@pytest.fixture
def folder(tmp_path):
    return tmp_path


def _run(folder, script: str, warm: bool, cancel: str = "never") -> launch.Outcome:
    (folder / "scene.py").write_text(script)
    return launch.run_command(["simulate", "scene.py", "--t-final", "0.01", "--no-plots"], str(folder),
                              str(folder / "stdout.txt"), str(folder / "stderr.txt"), str(folder / cancel), warm)


@pytest.mark.parametrize("warm", [True, False], ids=["warm", "fresh"])
def test_a_run_is_its_own_process_in_its_folder_with_its_cpu_and_memory(folder, warm):
    outcome = _run(folder, PROBE, warm)
    seen = json.loads((folder / "stdout.txt").read_text().splitlines()[0])
    assert outcome.launch == ("warm" if warm else "fresh")
    assert outcome.code == 2 and "RuntimeError: probe done" in (folder / "stderr.txt").read_text()
    assert seen["cwd"] == seen["path0"] == str(folder)   # as `python -m` run in the run's folder
    assert seen["pid"] != os.getpid() and seen["sid"] == seen["pid"]   # leads its own session
    assert seen["mpl"] == "Agg" and seen["omp"] == "1"
    # the launcher's CPU time (wait4 on the run) against the run's own account of itself just before it
    # ended: at least that; and for a forked run, not the warm server's imports (a second server measures
    # their CPU itself, before it forks anything), only the traceback and interpreter exit
    own = json.loads((folder / "stdout.txt").read_text().splitlines()[1])["cpu"]
    assert own >= 0.3 and own <= outcome.cpu_time
    if warm:
        other = launch.ForkServer()
        imports, _ = other.preload_cpu, other.close()
        # imports > 0: the server did preload (their CPU is the machine's: 0.405 s on 2026-12-05, 0.118 s on 12-06)
        assert imports > 0.05 and outcome.cpu_time < own + imports / 2
    assert outcome.max_rss_mb >= 120


@pytest.mark.parametrize("warm", [True, False], ids=["warm", "fresh"])
def test_cancel_stops_the_run_and_what_it_forked(folder, warm):
    pid_file = folder / "grandchild.pid"

    def cancel_when_started():
        end = time.monotonic() + 120
        while not pid_file.exists() and time.monotonic() < end:
            time.sleep(0.05)
        (folder / "cancel").touch()

    t = threading.Thread(target=cancel_when_started, daemon=True)
    t.start()
    outcome = _run(folder, HANG, warm, cancel="cancel")
    t.join()
    assert outcome.cancelled and outcome.code != 0
    assert _gone(int(pid_file.read_text()))   # the run's process group was signalled, not only the run


def _gone(pid: int, timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if psutil.Process(pid).status() == psutil.STATUS_ZOMBIE:
                return True
        except psutil.NoSuchProcess:
            return True
        time.sleep(0.05)
    return False


def test_a_crashed_run_leaves_the_warm_server_usable_and_a_dead_server_is_replaced(folder):
    crash = _run(folder, "import os\nos.abort()\n", warm=True)
    assert crash.code == -signal.SIGABRT and crash.launch == "warm"
    again = _run(folder, "raise SystemExit(7)\n", warm=True)
    assert again.code == 7 and again.launch == "warm" and launch.warm_status() == "warm"   # its exit status
    [server] = launch._IDLE
    server.proc.kill()   # as if killed while idle
    server.proc.wait()
    after = _run(folder, "raise SystemExit(7)\n", warm=True)
    assert after.code == 7 and after.launch == "warm" and launch._IDLE[0] is not server
