"""CasADi's OpenBLAS (MUMPS inside IPOPT) runs on one thread after a solve, unless the user chose a count.

Each case runs in a fresh process: the thread count is read from the environment when OpenBLAS loads."""

import json
import os
import subprocess
import sys

import pytest

CHILD = """
import json, threadpoolctl
import ocp_constraints as oc
from ocp_constraints.scenes.registry import build_task
def threads():
    return {i["internal_api"]: i["num_threads"] for i in threadpoolctl.threadpool_info()
            if i["internal_api"] in ("casadi_openblas", "openblas")}
from ocp_constraints.ocp.solver_threads import one_blas_thread
before = threads()
during = one_blas_thread(threads)()          # what problem.solve runs under
build_task("pendulum", "swing_up")[1].solve(method=oc.Radau(5, degree=3))
print(json.dumps({"before": before, "during": during, "after": threads()}))
"""


def _threads_in_child(**env_vars) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", CHILD], env={**env, **env_vars}, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_ipopt_solve_leaves_casadi_openblas_on_one_thread_and_numpy_as_it_was():
    seen = _threads_in_child()
    assert "casadi_openblas" not in seen["before"]          # loaded with the IPOPT plugin, by the first solve
    assert seen["after"]["casadi_openblas"] == 1
    if "openblas" in seen["before"]:                        # numpy's copy: one thread during a solve only
        assert seen["during"]["openblas"] == 1
        assert seen["after"]["openblas"] == seen["before"]["openblas"]


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: OpenBLAS starts one thread whatever is asked")
def test_a_thread_count_the_user_set_is_kept():
    seen = _threads_in_child(OPENBLAS_NUM_THREADS="2")
    assert seen["after"]["casadi_openblas"] == 2
    if "openblas" in seen["before"]:
        assert seen["during"]["openblas"] == seen["before"]["openblas"] == 2
