"""IPOPT's linear algebra on one thread, unless the user says otherwise.

CasADi's IPOPT factors its KKT matrices with MUMPS, whose dense kernels run on the OpenBLAS that
CasADi bundles (``libcasadi-tp-openblas``, loaded with the IPOPT plugin at the first
``casadi.nlpsol``). That OpenBLAS starts one thread per core. The fronts of a collocation NLP are
small, so the extra threads mostly wait for work, spinning, and numpy's own BLAS (the solutions'
interpolation, the error estimates) does the same on our small products. On 2 cores (medians of 3,
each solve in its own process, ``python scripts/solver_threads_bench.py``,
``results/bench/solver_threads.md``): the suite's quadrotor with a load refined to 1e-3 took 16.9 s
of wall time and 33 s of CPU with one thread per core, 4.6 s and 4.8 s on one; the walker, the
cart-pole (refined, and on a fixed mesh of 4,000 points), the ball-and-socket reach and the swing-up
took the same wall time both ways (ratios 0.95-1.04) and on one thread about half the CPU.

So after an IPOPT solver is created (:func:`ipopt_solver`), :func:`single_threaded_blas` limits CasADi's OpenBLAS to one
thread, once per process, through threadpoolctl, and :func:`one_blas_thread` holds numpy's BLAS to
one thread while ``problem.solve`` runs, giving it back as it was afterwards. A user who sets
``OPENBLAS_NUM_THREADS`` or ``OMP_NUM_THREADS`` keeps their own choice: then nothing is changed.
"""

from __future__ import annotations

import functools
import os

import casadi as ca
from threadpoolctl import OpenBLASController, ThreadpoolController, register, threadpool_limits

# The environment variables OpenBLAS reads for its thread count; one set by the user wins.
USER_SETTINGS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


class CasadiOpenBLAS(OpenBLASController):
    """threadpoolctl's OpenBLAS controller, for the copy CasADi ships under its own file name."""

    internal_api = "casadi_openblas"
    filename_prefixes = ("libcasadi-tp-openblas",)


register(CasadiOpenBLAS)
_done = False


def user_thread_setting() -> str | None:
    """The first of :data:`USER_SETTINGS` set in the environment (``NAME=value``), or None."""
    for name in USER_SETTINGS:
        if os.environ.get(name):
            return f"{name}={os.environ[name]}"
    return None


def single_threaded_blas() -> int:
    """Limit CasADi's OpenBLAS to one thread (see the module's notes); call after ``casadi.nlpsol``,
    which loads it. Returns how many copies were limited (0 once done, or when the user chose)."""
    global _done
    if _done or user_thread_setting() is not None:
        return 0
    found = ThreadpoolController().select(internal_api=CasadiOpenBLAS.internal_api).lib_controllers
    for blas in found:
        blas.set_num_threads(1)
    # Set for good (not a context): hand back threadpoolctl's one-controlling-thread lock, which
    # OpenBLAS controllers share, so a later threadpool_limits in any thread still works.
    CasadiOpenBLAS.clear_controlling_thread()
    _done = bool(found) and all(blas.get_num_threads() == 1 for blas in found)
    return len(found) if _done else 0


def ipopt_solver(name: str, nlp: dict, options: dict) -> ca.Function:
    """``casadi.nlpsol(name, "ipopt", nlp, options)``, then CasADi's OpenBLAS on one thread (:func:`single_threaded_blas`):
    every IPOPT solver of the library is made here."""
    solver = ca.nlpsol(name, "ipopt", nlp, options)
    single_threaded_blas()
    return solver


def one_blas_thread(function):
    """``function`` (a solve) run with every loaded BLAS on one thread, each given back its own count after
    (see the module's notes); unchanged where the user chose a count (:func:`user_thread_setting`)."""

    @functools.wraps(function)
    def limited(*args, **kwargs):
        if user_thread_setting() is not None:
            return function(*args, **kwargs)
        with threadpool_limits(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return limited
