"""``ocp-constraints batch`` on real Dask clusters (no mocks).

Spec expansion (Cartesian product, stable ids, globs, errors naming the spec file and
sweep); a LocalCluster batch of 13 quick simulations (12 pendulums and a scene file
that raises) whose numbers equal the same commands run one by one; resume after a
deleted ``done.json`` and after Ctrl-C; a separately started ``dask scheduler`` with two
``dask worker`` processes: ``--scheduler`` gives the same table, and killing a worker in
the middle of a batch loses nothing. Everything listens on 127.0.0.1 only.
"""
from __future__ import annotations

import _thread
import argparse
import itertools
import json
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from ocp_constraints.batch import BatchSpecError, load_spec, read_table, run_batch
from ocp_constraints.cli.batch import add_batch_parser

try:
    import distributed
except ImportError:   # the batch extra is not installed
    distributed = None
needs_dask = pytest.mark.skipif(distributed is None, reason='needs dask[distributed]: pip install -e ".[batch]"')

DASK = str(Path(sys.executable).with_name("dask"))
SIM = ["simulate", "pendulum", "--t-final", "0.05", "--dt", "0.01", "--no-plots"]
LENGTHS, ANGLES = [0.5, 1.0, 1.5, 2.0], [30, 45, 60]
SPEC = """
[[sweep]]
args = {sim}
L = {lengths}
a = {angles}
"""
BROKEN = """
[[sweep]]
args = ["simulate", "{scene}", "--t-final", "0.05", "--no-plots"]
scene = { glob = "scenes/*.py" }
"""
ONE_BY_ONE = """
import json, runpy, sys
for argv in json.loads(sys.argv[1]):
    sys.argv = ["ocp_constraints", *argv]
    try:
        runpy.run_module("ocp_constraints", run_name="__main__", alter_sys=True)
    except SystemExit as exc:
        assert not exc.code, (argv, exc.code)
"""
NUMBERS = ["t_reached", "max_constraint_residual.position", "max_constraint_residual.velocity",
           "energy.relative_error"]


def _write_spec(folder: Path, lengths=LENGTHS, angles=ANGLES, broken: bool = True, t_final: str = "0.05") -> Path:
    """12 pendulums (length x release angle) and, if ``broken``, a scene file that raises.
    ``t_final``: simulated seconds per run (0.05: ~0.15 s of a forked run; 60: ~1 s)."""
    (folder / "scenes").mkdir(parents=True, exist_ok=True)
    (folder / "scenes" / "broken_scene.py").write_text('raise RuntimeError("boom")\n')
    sim = json.dumps(_sim(t_final) + ["--param", "length={L}", "--param", "angle0_deg={a}"])
    path = folder / "spec.toml"
    path.write_text(SPEC.format(sim=sim, lengths=json.dumps(lengths), angles=json.dumps(angles))
                    + (BROKEN if broken else ""))
    return path


def _sim(t_final: str) -> list[str]:
    return [t_final if a == "0.05" else a for a in SIM]


def _cli(argv: list[str]) -> int:
    """The batch subcommand's parser and handler, as the command line runs them."""
    parser = argparse.ArgumentParser(prog="ocp-constraints")
    add_batch_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.handler(args)


def _mtimes(out: Path) -> dict[str, int]:
    return {d.name: (d / "stdout.txt").stat().st_mtime_ns for d in (out / "runs").iterdir() if d.is_dir()}


def _wait_for(predicate, timeout: float = 120.0, what: str = "condition"):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


# -- spec ---------------------------------------------------------------------------------
def test_spec_cartesian_product_stable_ids_and_glob(tmp_path):
    for trial in ("s1", "s2"):
        (tmp_path / "data" / trial).mkdir(parents=True)
    (tmp_path / "data" / "notes.txt").write_text("not a folder")
    spec = tmp_path / "spec.toml"
    spec.write_text("""
[[sweep]]
args = ["solve", "pendulum", "--scheme", "radau", "--degree", "{d}", "--intervals", "{N}"]
d = [3, 5]
N = [20, 40, 80]
[[sweep]]
args = ["knee", "--model", "{model}", "--motion", "{trial}/IK.mat", "--out", "{out}"]
model = ["m.osim"]
trial = { glob = "data/*/" }
""")
    runs = load_spec(spec)
    assert [r.args[5::2] for r in runs[:6]] == [(d, n) for d in ("3", "5") for n in ("20", "40", "80")]
    assert [r.values for r in runs[:2]] == [{"d": "3", "N": "20"}, {"d": "3", "N": "40"}]
    assert runs[0].id.startswith("solve-pendulum-d=3-N=20-")
    motions = [r.args[4] for r in runs[6:]]
    assert motions == [str(tmp_path / "data" / t) + "/IK.mat" for t in ("s1", "s2")]   # absolute, sorted
    assert runs[6].id.startswith("knee-model=m.osim-trial=s1-")
    assert runs[6].args[-1] == "{out}" and runs[6].command_args("/x/runs/y")[-1] == "/x/runs/y"
    assert {r.cwd for r in runs} == {str(tmp_path)} and {r.sweep for r in runs} == {1, 2}
    assert len({r.id for r in runs}) == 8
    assert [r.id for r in load_spec(spec)] == [r.id for r in runs]   # stable across expansions
    other = tmp_path / "elsewhere"
    other.mkdir()
    shutil.copy(spec, other / "spec.toml")
    (other / "data" / "s1").mkdir(parents=True)
    assert [r.id for r in load_spec(other / "spec.toml")[:6]] == [r.id for r in runs[:6]]


@pytest.mark.parametrize("body, fragment", [
    ('[[sweep]]\nargs = ["simulate", "{scene}"]\n', "sweep 1 (args): unknown placeholder(s) {scene}"),
    ('[[sweep]]\nargs = ["simulate", "{L}"]\nL = []\n', "sweep 1 (L): empty list"),
    ('[[sweep]]\nargs = ["simulate", "{L}"]\nL = 3\n', "sweep 1 (L): must be a list"),
    ('[[sweep]]\nargs = ["list"]\n[[sweep]]\nargs = ["simulate", "{L}"]\nL = [1]\nM = [2]\n',
     "sweep 2 (M): variable is not used"),
    ('[[sweep]]\nargs = ["simulate", "{s}"]\ns = { glob = "nothing/*.py" }\n', "sweep 1 (s): glob 'nothing/*.py'"),
    ('[[sweep]]\nargs = ["list"]\n[[sweep]]\nargs = ["list"]\n', "sweep 2: duplicate run id 'list-"),
    ('[[sweep]]\nargs = ["list", "--out", "{out}"]\nout = ["x"]\n', "sweep 1 (out): 'out' is reserved"),
    ('[[sweep]]\nargs = "simulate pendulum"\n', "sweep 1: 'args' must be a non-empty list"),
    ('[[run]]\nargs = ["list"]\n', "unknown top-level key(s) 'run'"),
    ('[[sweep]\n', "not valid TOML"),
])
def test_spec_errors_name_the_file_sweep_and_key(tmp_path, body, fragment):
    spec = tmp_path / "bad_spec.toml"
    spec.write_text(body)
    with pytest.raises(BatchSpecError) as err:
        load_spec(spec)
    assert "bad_spec.toml" in str(err.value) and fragment in str(err.value)


def test_cli_reports_bad_spec_and_missing_dask(tmp_path, capsys):
    spec = tmp_path / "bad_spec.toml"
    spec.write_text('[[sweep]]\nargs = ["simulate", "{L}"]\nL = []\n')
    assert _cli(["batch", str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "bad_spec.toml: sweep 1 (L): empty list" in err and err.count("\n") == 1
    code = ("import runpy, sys; sys.modules['dask.distributed'] = sys.modules['distributed'] = None\n"
            f"sys.argv = ['ocp-constraints', 'batch', {str(spec)!r}, '--out', 'x']\n"
            "runpy.run_module('ocp_constraints', run_name='__main__', alter_sys=True)")   # python -m, no Dask
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    assert p.stderr.strip() == 'error: ocp-constraints batch needs Dask: pip install -e ".[batch]"'


# -- a LocalCluster -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address="127.0.0.1:0")
    try:
        with distributed.Client(cluster) as c:
            yield c
    finally:
        cluster.close()


@pytest.fixture(scope="module")
def spec(tmp_path_factory) -> Path:
    return _write_spec(tmp_path_factory.mktemp("spec"))


@pytest.fixture(scope="module")
def local_batch(client, spec, tmp_path_factory):
    return run_batch(spec, tmp_path_factory.mktemp("local") / "out", client=client, progress=False)


@needs_dask
def test_batch_equals_the_runs_one_by_one(local_batch, tmp_path):
    rows = {r["id"]: r for r in read_table(local_batch.out)}
    assert len(rows) == 13 and local_batch.counts["succeeded"] == 12
    typed = {r["id"]: r for r in json.loads((local_batch.out / "batch.json").read_text())["runs"]}
    combos = list(itertools.product(LENGTHS, ANGLES))
    argvs = [SIM + ["--param", f"length={L}", "--param", f"angle0_deg={a}", "--out", str(tmp_path / f"single{k}")]
             for k, (L, a) in enumerate(combos)]
    # The same commands one after the other, each as `python -m ocp_constraints ARGS` does it,
    # in one process (a process each would cost the 2-core budget another ~10 s).
    subprocess.run([sys.executable, "-c", ONE_BY_ONE, json.dumps(argvs)], check=True, timeout=600, cwd=tmp_path)
    summaries = [json.loads((tmp_path / f"single{k}" / "summary.json").read_text()) for k in range(len(combos))]
    for (L, a), summary in zip(combos, summaries):
        [rid] = [i for i, r in typed.items() if r.get("var.L") == str(L) and r.get("var.a") == str(a)]
        row, csv_row = typed[rid], rows[rid]
        assert row["status"] == "succeeded" and row["exit_code"] == 0 and row["worker"].startswith("tcp://127.0.0.1:")
        assert row["success"] is True and csv_row["success"] == "true"
        for key in NUMBERS:
            section, _, name = key.partition(".")
            expected = summary[section][name] if name else summary[section]
            assert row[key] == expected and float(csv_row[key]) == expected, (rid, key)
        folder = local_batch.out / "runs" / rid
        assert json.loads((folder / "summary.json").read_text())["parameters"]["length"] == L
        assert "results in" in (folder / "stdout.txt").read_text()
        assert json.loads((folder / "done.json").read_text())["launch"] == "warm"   # forked from a warm server


@needs_dask
def test_a_failing_run_is_one_failed_row_with_its_message(local_batch):
    rows = read_table(local_batch.out)
    failed = [r for r in rows if r["status"] != "succeeded"]
    assert len(failed) == 1 and not local_batch.ok
    [row] = failed
    assert row["status"] == "failed" and row["exit_code"] == "2" and row["id"].startswith("simulate-scene=broken_scene.py-")
    assert row["message"].startswith("error: scene file") and "RuntimeError: boom" in row["message"]
    folder = local_batch.out / "runs" / row["id"]
    assert "RuntimeError: boom" in (folder / "stderr.txt").read_text() and not (folder / "done.json").exists()


@needs_dask
def test_resume_runs_only_what_is_missing(local_batch, spec, tmp_path, capsys):
    """Through the command, on its own embedded cluster (--workers 1)."""
    out = tmp_path / "out"
    shutil.copytree(local_batch.out, out)
    rows = read_table(out)
    redo = rows[4]["id"]
    failed = next(r["id"] for r in rows if r["status"] == "failed")
    (out / "runs" / redo / "done.json").unlink()
    before = _mtimes(out)
    assert _cli(["batch", str(spec), "--out", str(out), "--resume", "--workers", "1"]) == 1   # one run fails
    status = {r["id"]: r["status"] for r in read_table(out)}
    assert status.pop(redo) == "succeeded" and status.pop(failed) == "failed"   # a failed run is run again
    assert set(status.values()) == {"skipped"} and len(status) == 11
    after = _mtimes(out)
    assert {k for k in before if after[k] != before[k]} == {redo, failed}
    assert "batch: 1 succeeded, 1 failed, 11 skipped (of 13 runs)" in capsys.readouterr().out
    assert json.loads((out / "batch.json").read_text())["counts"] == {
        "pending": 0, "succeeded": 1, "failed": 1, "skipped": 11, "cancelled": 0}


@needs_dask
def test_ctrl_c_leaves_a_consistent_table_and_resume_finishes(client, tmp_path, capsys):
    # One short run and three of about 1 s each: whichever finishes first, Ctrl-C then finds at least
    # one run unfinished however late the main thread sees it (a forked run of 0.05 s simulated time
    # takes ~0.15 s, so four short runs could all end before the interrupt is handled).
    long_sim = _sim("60")
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC.format(sim=json.dumps(SIM + ["--param", "length={L}"]), lengths="[1.1]", angles="[]")
                    .replace("a = []\n", "")
                    + SPEC.format(sim=json.dumps(long_sim + ["--param", "length={L}"]), lengths="[1.2, 1.3, 1.4]",
                                  angles="[]").replace("a = []\n", ""))
    assert len(load_spec(spec)) == 4
    out = tmp_path / "out"

    def interrupt_after_first_run():
        _wait_for(lambda: list((out / "runs").glob("*/done.json")) if (out / "runs").is_dir() else [],
                  what="a first finished run")
        _thread.interrupt_main()   # what Ctrl-C does

    t = threading.Thread(target=interrupt_after_first_run, daemon=True)
    # Ctrl-C as an interactive shell delivers it: interrupt_main does nothing where SIGINT is ignored (a job
    # started in the background, as under nohup)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        t.start()
        with pytest.raises(KeyboardInterrupt):
            run_batch(spec, out, client=client, progress=False)
    finally:
        signal.signal(signal.SIGINT, previous)
    t.join()
    rows = read_table(out)
    assert len(rows) == 4 and json.loads((out / "batch.json").read_text())["interrupted"] is True
    status = {r["id"]: r["status"] for r in rows}
    assert set(status.values()) == {"succeeded", "cancelled"}
    for rid, s in status.items():
        assert (out / "runs" / rid / "done.json").exists() == (s == "succeeded")
    before = _mtimes(out)
    capsys.readouterr()
    run_batch(spec, out, client=client, resume=True, progress=True)
    err = capsys.readouterr().err   # the dashboard's address and the progress line
    n = list(status.values()).count("cancelled")
    assert "Dask dashboard: http://127.0.0.1:" in err and f"\rbatch: {n}/{n} done, 0 failed, 0 running" in err
    resumed = {r["id"]: r["status"] for r in read_table(out)}
    assert resumed == {rid: "skipped" if s == "succeeded" else "succeeded" for rid, s in status.items()}
    after = _mtimes(out)
    assert all(after[rid] == before[rid] for rid, s in status.items() if s == "succeeded")


# -- a separately started scheduler and workers ---------------------------------------------
@pytest.fixture(scope="module")
def external(tmp_path_factory):
    """``dask scheduler`` and two ``dask worker`` processes (no nanny: killing one kills the worker)."""
    folder = tmp_path_factory.mktemp("dask")
    procs: dict[str, subprocess.Popen] = {}
    log = open(folder / "dask.log", "wb")
    try:
        procs["scheduler"] = subprocess.Popen(
            [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(folder / "scheduler.json")], stdout=log, stderr=subprocess.STDOUT)
        address = _wait_for(lambda: (folder / "scheduler.json").is_file() and
                            json.loads((folder / "scheduler.json").read_text() or "{}").get("address"),
                            what="the scheduler")
        for name in ("w0", "w1"):
            procs[name] = subprocess.Popen(
                [DASK, "worker", address, "--name", name, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                 "--no-dashboard", "--death-timeout", "60"], stdout=log, stderr=subprocess.STDOUT)
        with distributed.Client(address, timeout="60s") as c:
            c.wait_for_workers(2, timeout=120)
        yield address, procs
    finally:   # workers first, then the scheduler
        for group in ([p for n, p in procs.items() if n != "scheduler"], [procs.get("scheduler")]):
            for p in filter(None, group):
                p.terminate()
            for p in filter(None, group):
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        log.close()


@needs_dask
def test_scheduler_address_gives_the_same_table(external, local_batch, spec, tmp_path):
    address, _ = external
    assert address.startswith("tcp://127.0.0.1:")
    out = tmp_path / "out"
    assert _cli(["batch", str(spec), "--out", str(out), "--scheduler", address, "--no-progress"]) == 1  # one failed

    def comparable(rows):
        varying = ("wall_time", "cpu_time", "max_rss_mb", "worker")
        return [{k: v for k, v in r.items() if k not in varying} for r in rows]

    remote, local = read_table(out), read_table(local_batch.out)
    assert comparable(remote) == comparable(local)
    assert len({r["worker"] for r in remote}) == 2
    assert (out / "batch.csv").read_text().splitlines()[0] == (local_batch.out / "batch.csv").read_text().splitlines()[0]


@needs_dask
def test_a_worker_killed_mid_batch_loses_nothing(external, tmp_path):
    """Runs last on this cluster: it kills one of its workers."""
    address, procs = external
    # runs of ~1 s: short ones (~0.15 s forked) could all end before a busy worker is seen
    spec = _write_spec(tmp_path, lengths=[0.7], angles=[11, 22, 33], broken=False, t_final="60")
    out = tmp_path / "out"
    with distributed.Client(address, timeout="60s") as c:
        names = {a: w["name"] for a, w in c.scheduler_info()["workers"].items()}
        done = {}
        t = threading.Thread(target=lambda: done.update(result=run_batch(spec, out, client=c, progress=False)))

        def busy_worker():   # after a first result: a worker running one of our runs not finished yet
            if not t.is_alive():
                return "batch over"
            if not list((out / "runs").glob("*/done.json")):
                return None
            for addr, keys in c.processing().items():
                for key in keys:
                    rid = key.rsplit("-", 1)[0]   # keys are <run id>-<batch token>
                    if not (out / "runs" / rid / "done.json").exists():
                        return addr, rid
            return None

        t.start()
        try:
            found = _wait_for(busy_worker, what="a first result and a busy worker")
            assert found != "batch over", f"the batch ended before a worker could be killed: {read_table(out)}"
            addr, victim_run = found
            procs[names[addr]].kill()
            procs[names[addr]].wait()
        finally:
            t.join(timeout=300)
        rows = read_table(out)
        assert addr not in c.scheduler_info()["workers"]
    assert sorted(r["id"] for r in rows) == sorted({r["id"] for r in rows}) and len(rows) == 3
    assert {r["status"] for r in rows} == {"succeeded"} and done["result"].ok
    assert all((out / "runs" / r["id"] / "done.json").is_file() for r in rows)
    [victim] = [r for r in rows if r["id"] == victim_run]
    assert victim["worker"] != addr   # rescheduled: it ran again on the surviving worker
