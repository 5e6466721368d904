"""Multi-start optimal control: perturbed initial guesses, the best local optimum kept, the spread reported.

The transcribed NLPs are non-convex (the swing-up has a one-way and a two-way swing; the
``ball_socket`` reach has several optima between 0.80 and 0.89), so which local optimum IPOPT
reaches depends on the start. :func:`solve_multistart` solves the problem from ``starts``
initial guesses and keeps the best successful solution:

* start 0 is the problem's own guess (its ``set_guess`` functions, else the coordinates
  linear between their boundary values), so the result is never worse than a single solve;
* start ``k >= 1`` adds to every coordinate, and to every input that has a guess, a random
  smooth perturbation ``delta(s) = A r sum_{m=1..3} a_m sin(m pi s) / m`` of the normalized
  time ``s = t / T`` (``a_m`` standard normal), plus ``b (1 - s)`` / ``b' s`` at an end where the
  user fixed no value: zero at every end the user fixed, so the boundary values hold. ``r``
  is the quantity's range: its bound width if both bounds are finite, else the span of the
  unperturbed guess over the horizon; ``A`` is ``amplitude`` (default 0.5). A quantity whose
  guess is constant and unbounded is left alone: such coordinates are mostly ones the
  constraints hold (a hinge's fixed angles), and moving them only sends the projection onto
  the constraints to another branch of the Euler angles. The draws of start ``k`` come from
  ``numpy.random.default_rng([seed, k])``: the same start whatever the number of starts and
  wherever it runs. From the perturbed coordinates, :mod:`.guess` makes a consistent start as
  for any guess (positions projected onto the constraints, speeds fitted, multipliers and the
  inputs without a guess by pointwise inverse dynamics).

Locally, the starts run one after another in this process and share one transcription. With a
Dask ``client`` (anything with ``submit`` and ``gather``, e.g. ``distributed.Client``) each
start is a task: the problem goes to the workers pickled by cloudpickle in a CasADi pickling
context (SX expressions and Functions keep their shared symbols), each task builds the
transcription, solves its start and returns the decision vector and IPOPT's statistics; the
best one is rebuilt here as an :class:`~ocp_constraints.ocp.solution.OCPSolution`. The workers
need ``ocp_constraints`` installed, and a problem whose guesses or expressions come from a scene
file need that file's code to be picklable (built-in scenes and lambdas are).

The result carries ``sol.starts``, one ``(objective, status, iterations)`` per start,
``sol.local_optima`` (the successful objectives clustered to the relative tolerance ``rtol``:
``objective`` the lowest of a cluster, ``count``, ``starts``) and ``sol.multistart``, a JSON-ready
summary (seed, counts, best start, the optima, their spread, wall time).
"""
from __future__ import annotations

import copy
import hashlib
import math
import pickle
import threading
import time
from typing import NamedTuple

import numpy as np

from ..errors import ModelError, OCPSolveError

MODES = 3                 # sine modes of a perturbation
DEFAULT_AMPLITUDE = 0.5   # perturbation amplitude relative to each quantity's range
DEFAULT_RTOL = 1e-5       # objectives within this relative distance are one local optimum
SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
# What a problem keeps of its solves (problem.transcription's NLPs with their IPOPT instances; the element
# kinds of transcription_elements and their derivatives of nlp_assembly; their compiled copies of
# compiled_elements, libraries loaded in this process): not sent to Dask workers.
LOCAL_CACHES = ("_transcriptions", "_element_kinds", "_element_derivatives", "_machine_code")


class StartRecord(NamedTuple):
    """One start: IPOPT's objective, status and iteration count (a failed start: its last iterate's)."""

    objective: float
    status: str
    iterations: int


# -- guesses ---------------------------------------------------------------------------------------
class _Linear:
    """``a + (b - a) t / T``: the default guess of a coordinate between its boundary values."""

    def __init__(self, a: float, b: float, T: float):
        self.a, self.b, self.T = a, b, T

    def __call__(self, t):
        return self.a + (self.b - self.a) * np.asarray(t, float) / self.T


class _Tabulated:
    """A quantity of a warm-start solution, linear between its collocation points."""

    def __init__(self, t: np.ndarray, values: np.ndarray):
        self.t, self.values = np.asarray(t, float), np.asarray(values, float)

    def __call__(self, t):
        return np.interp(np.asarray(t, float), self.t, self.values)


class _Perturbed:
    """``base(t) + scale (sum_m a_m sin(m pi s) / m + b0 (1 - s) + b1 s)``, ``s = t / T``."""

    def __init__(self, base, scale: float, a: np.ndarray, b0: float, b1: float, T: float):
        self.base, self.scale, self.a, self.b0, self.b1, self.T = base, scale, a, b0, b1, T

    def __call__(self, t):
        t = np.asarray(t, float)
        s = t / self.T
        modes = sum(am * np.sin((m + 1) * math.pi * s) / (m + 1) for m, am in enumerate(self.a))
        return np.asarray(self.base(t), float) + self.scale * (modes + self.b0 * (1 - s) + self.b1 * s)


def base_guesses(problem, guesses: dict | None = None) -> dict:
    """The unperturbed guess (name -> callable) of every coordinate, and of every input that has one in
    ``guesses`` (default: the problem's ``set_guess`` functions); a coordinate without one is linear
    between its boundary values, as :meth:`Transcription.initial_guess` makes it."""
    guesses = problem.guess if guesses is None else guesses
    T = float(problem.t_final)
    out = {}
    for n in problem.model.coordinate_names:
        if n in guesses:
            out[n] = guesses[n]
        else:
            a = problem.initial_values.get(n, problem.final_values.get(n, 0.0))
            out[n] = _Linear(a, problem.final_values.get(n, a), T)
    out.update({n: guesses[n] for n in problem.model.inputs if n in guesses})
    return out


def warm_start_guesses(problem, solution) -> dict:
    """Coordinates and inputs of a solution of this problem as guesses (linear between its points,
    its time scaled to the problem's horizon)."""
    t = np.asarray(solution.t, float) / float(solution.t_final) * float(problem.t_final)
    return {n: _Tabulated(t, solution.sample(n)) for n in problem.model.coordinate_names + list(problem.model.inputs)}


def _ranges(problem, base: dict) -> dict[str, float]:
    """Each quantity's range: its bound width if both bounds are finite, else the span of its guess
    over the horizon (zero for a quantity the guess keeps constant: it is not perturbed)."""
    t = np.linspace(0.0, float(problem.t_final), 201)
    out = {}
    for n, f in base.items():
        lo, hi = problem.bounds.get(n, (-np.inf, np.inf))
        v = np.broadcast_to(np.asarray(f(t), float), t.shape)
        span = float(np.nanmax(v) - np.nanmin(v)) if np.isfinite(v).any() else 0.0
        out[n] = hi - lo if np.isfinite(lo) and np.isfinite(hi) else span
    return out


def perturbed_guesses(problem, k: int, seed: int, amplitude: float = DEFAULT_AMPLITUDE,
                      guesses: dict | None = None) -> dict:
    """The guess dict of start ``k`` around ``guesses`` (default: the problem's own); start 0 is unperturbed."""
    guesses = problem.guess if guesses is None else guesses
    base = base_guesses(problem, guesses)
    out = {**guesses, **base}
    if k == 0:
        return out
    rng = np.random.default_rng([int(seed), int(k)])
    T = float(problem.t_final)
    for n, r in _ranges(problem, base).items():
        a, b = rng.standard_normal(MODES), rng.standard_normal(2)
        if r > 0:
            out[n] = _Perturbed(base[n], amplitude * r, a, 0.0 if n in problem.initial_values else b[0],
                                0.0 if n in problem.final_values else b[1], T)
    return out


# -- one start -------------------------------------------------------------------------------------
def _solve_start(problem, method, k: int, seed: int, amplitude: float, ipopt_options, guesses: dict, progress):
    """Solve start ``k`` here; returns ``(solution or None, record)`` (a failed start keeps its last iterate)."""
    saved = problem.guess
    problem.guess = perturbed_guesses(problem, k, seed, amplitude, guesses)
    try:
        sol = problem.solve(method, ipopt_options, check=False, progress=progress)
    except OCPSolveError as exc:
        sol = exc.solution
    finally:
        problem.guess = saved
    if sol is None:
        return None, StartRecord(float("nan"), "no iterate", 0)
    return sol, StartRecord(float(sol.objective), sol.status, sol.iterations)


_WORKER_PROBLEMS: dict = {}
_WORKER_LOCK = threading.Lock()


def _solve_start_remote(payload: bytes, k: int) -> dict:
    """A Dask task: unpickle the problem, solve start ``k``, return the decision vector and statistics."""
    import casadi as ca

    started = time.perf_counter()
    try:
        key = hashlib.sha1(payload).hexdigest()
        # One problem and its transcription per worker process, reused by its later starts; one
        # solve at a time (a transcription holds one IPOPT instance; a worker may run threads).
        with _WORKER_LOCK:
            if key not in _WORKER_PROBLEMS:
                with ca.global_unpickle_context():
                    loaded = pickle.loads(payload)
                _WORKER_PROBLEMS.clear()
                _WORKER_PROBLEMS[key] = loaded
            problem, method, seed, amplitude, ipopt_options, guesses = _WORKER_PROBLEMS[key]
            sol, _ = _solve_start(problem, method, k, seed, amplitude, ipopt_options, guesses, False)
    except Exception as exc:  # noqa: BLE001 - a start that cannot run is reported, not raised on the worker
        return {"k": k, "error": f"{type(exc).__name__}: {exc}", "wall": time.perf_counter() - started}
    if sol is None:
        return {"k": k, "error": "IPOPT returned no iterate", "wall": time.perf_counter() - started}
    return {"k": k, "w": np.asarray(sol.decision_vector, float), "stats": _plain(sol.stats),
            "objective": float(sol.objective), "wall_time": dict(sol.wall_time)}


def _plain(stats: dict) -> dict:
    """IPOPT's statistics without what need not travel (functions, callbacks)."""
    return {k: v for k, v in stats.items() if isinstance(v, (bool, int, float, str, dict, list, tuple, type(None)))}


# -- the spread of local optima --------------------------------------------------------------------
def cluster_objectives(objectives: dict[int, float], rtol: float = DEFAULT_RTOL) -> list[dict]:
    """Distinct local optima: objectives (start -> value) sorted and split where consecutive values
    differ by more than ``rtol`` relative; each cluster's ``objective`` is its lowest value."""
    clusters: list[dict] = []
    for k, f in sorted(objectives.items(), key=lambda kv: kv[1]):
        if clusters and f - clusters[-1]["objective"] <= rtol * max(abs(f), abs(clusters[-1]["objective"]), 1e-300):
            clusters[-1]["count"] += 1
            clusters[-1]["starts"] = sorted([*clusters[-1]["starts"], k])
        else:
            clusters.append({"objective": f, "count": 1, "starts": [k]})
    return clusters


# -- the driver ------------------------------------------------------------------------------------
def solve_multistart(problem, method, starts: int, seed: int = 0, client=None, ipopt_options: dict | None = None,
                     warm_start=None, *, check: bool = True, progress: bool | None = None,
                     amplitude: float = DEFAULT_AMPLITUDE, rtol: float = DEFAULT_RTOL):
    """Solve ``problem`` with ``method`` from ``starts`` guesses and return the best successful solution.

    ``seed`` (int) fixes the perturbations; ``client``: a Dask client to run the starts on (default:
    one after another in this process); ``warm_start``: a solution whose trajectory is the
    unperturbed guess (start 0) around which the others are drawn. ``amplitude``: perturbation
    size relative to each quantity's range; ``rtol``: relative tolerance that makes two objectives one
    local optimum. The solution carries ``starts``, ``local_optima`` and ``multistart`` (module
    docstring). If no start succeeds, :class:`~ocp_constraints.errors.OCPSolveError` is raised with
    start 0's last iterate (also carrying ``starts``); so is an interruption (SIGINT/SIGTERM), with
    the best solution so far.
    """
    if isinstance(starts, bool) or not isinstance(starts, (int, np.integer)) or starts < 1:
        raise ModelError(f"starts must be a whole number >= 1 (the number of initial guesses), got {starts!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed must be a whole number >= 0, got {seed!r}")
    if not (np.isfinite(amplitude) and amplitude >= 0):
        raise ModelError(f"amplitude must be a number >= 0 (relative to each quantity's range), got {amplitude!r}")
    if client is not None and not all(hasattr(client, a) for a in ("submit", "gather")):
        raise ModelError(f"client must be a Dask client (with submit and gather), got {type(client).__name__}")
    clock = time.perf_counter()
    problem.structure_key()                      # a model edited after the problem is refused first
    if check:
        from .diagnostics import check_problem

        check_problem(problem, method)
    guesses = problem.guess if warm_start is None else warm_start_guesses(problem, warm_start)
    interrupted = None
    if client is None:
        solutions, records = {}, []
        for k in range(starts):
            sol, record = _solve_start(problem, method, k, seed, amplitude, ipopt_options, guesses, progress)
            records.append(record)
            if sol is not None:
                solutions[k] = sol
            if record.status.startswith("interrupted"):
                interrupted = record.status
                break
    else:
        solutions, records = _run_on_client(problem, method, starts, seed, amplitude, ipopt_options, guesses, client)
    ok = {k: r.objective for k, r in enumerate(records) if r.status in SUCCESS and np.isfinite(r.objective)}
    optima = cluster_objectives(ok, rtol)
    best = min(ok, key=ok.get) if ok else None
    summary = {"starts": starts, "seed": int(seed), "amplitude": amplitude, "rtol": rtol, "succeeded": len(ok),
               "best_start": best, "optima": optima,
               "spread": (optima[-1]["objective"] - optima[0]["objective"]) if optima else None,
               "executor": "in-process" if client is None else f"dask ({type(client).__name__})",
               "wall_time_s": time.perf_counter() - clock,
               "runs": [{"objective": r.objective if np.isfinite(r.objective) else None, "status": r.status,
                         "iterations": r.iterations} for r in records]}
    chosen = solutions.get(best) if best is not None else solutions.get(0)
    if chosen is not None:
        chosen.starts, chosen.local_optima, chosen.multistart = list(records), optima, summary
    if interrupted or best is None:
        reason = (f"{interrupted} after {len(records)} of {starts} starts" if interrupted else
                  f"none of the {starts} starts succeeded (statuses: {', '.join(sorted({r.status for r in records}))})")
        raise OCPSolveError(f"multi-start of '{problem.model.name}' with {method.label} (N = {method.intervals}): "
                            f"{reason}; " + ("the best solution so far is kept in .solution" if best is not None
                                             else "start 0's last iterate is kept in .solution"), chosen)
    return chosen


def _run_on_client(problem, method, starts, seed, amplitude, ipopt_options, guesses, client):
    """Submit the starts to ``client``; rebuild every returned start here (one shared transcription)."""
    import casadi as ca
    import cloudpickle

    from .solution import OCPSolution

    # The NLP cache (IPOPT instances) and the element caches stay here: workers build their own.
    clone = copy.copy(problem)
    clone.__dict__ = {k: v for k, v in problem.__dict__.items() if k not in LOCAL_CACHES}
    with ca.global_pickle_context():
        payload = cloudpickle.dumps((clone, method, int(seed), float(amplitude), ipopt_options or {}, guesses))
    futures = [client.submit(_solve_start_remote, payload, k) for k in range(starts)]
    results = client.gather(futures)
    tr = problem.transcription(method)
    solutions, records = {}, []
    for res in sorted(results, key=lambda r: r["k"]):
        if "error" in res:
            records.append(StartRecord(float("nan"), f"error: {res['error']}", 0))
            continue
        sol = OCPSolution.from_vector(tr, res["w"], res["stats"], res["objective"], res["wall_time"])
        solutions[res["k"]] = sol
        records.append(StartRecord(float(sol.objective), sol.status, sol.iterations))
    return solutions, records
