"""Multi-start optimal control (``problem.solve(method, starts=K, seed=S, client=...)``).

The pendulum swing-up has two local optima, each checked against Pontryagin's conditions
solved by SciPy (collocation BVP, then shooting with DOP853 at rtol 1e-13; no library code):
the two-way swing (8.913005, :class:`~ocp_constraints.bench.references.SwingUpReference`)
and the one-way swing (13.670837, the extremal the same conditions reach from ``psi = 3``).
From the straight-line guess ``psi = pi t / T`` IPOPT reaches the one-way swing; the
multi-start must find the two-way one and report both.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

import ocp_constraints as oc
from ocp_constraints.bench.references import SwingUpReference
from ocp_constraints.ocp.multistart import cluster_objectives, perturbed_guesses
from ocp_constraints.scenes.registry import load_scene_module

METHOD = oc.Radau(20, degree=3)
# Radau 3 on 20 intervals: objective error about 1.2e-3 (order 5 from the README's 3.8e-5 at
# N = 40), 1.4e-4 relative; measured 1.3e-4 (two-way) and 2.1e-5 (one-way). Bound 3e-4 relative.
REL = 3e-4


class _ExtremalFrom(SwingUpReference):
    """The swing-up extremal that Pontryagin's conditions reach from the constant guess ``psi``."""

    def __init__(self, p: dict, psi: float):
        self.psi_guess = psi
        super().__init__(p)

    def _costates_by_collocation(self) -> np.ndarray:
        t = np.linspace(0.0, self.T, 41)
        y = np.vstack([np.full_like(t, self.psi_guess), np.zeros((3, t.size))])
        res = solve_bvp(lambda t, y: np.array(self._rhs(t, y)),
                        lambda a, b: np.array([a[0], a[1], b[0] - math.pi, b[1]]), t, y, tol=1e-8, max_nodes=100000)
        assert res.status == 0, res.message
        return res.sol(0.0)[2:]


@pytest.fixture(scope="module")
def optima() -> dict[str, float]:
    p = dict(load_scene_module("pendulum").DEFAULTS)
    return {"two-way": SwingUpReference(p).objective, "one-way": _ExtremalFrom(p, 3.0).objective}


def _straight_line_swing_up():
    _, problem = oc.build_task("pendulum", "swing_up")
    # The maximal form: from these starts it finds exactly the two extremals below (in joint
    # coordinates one start lands on a third local optimum, 9.449).
    problem.coordinates = "maximal"
    problem.set_guess("rod.psi", lambda t: math.pi * t / 2)
    # A constant forward torque with the straight line: from this start IPOPT lands on the
    # one-way swing (the straight line alone now reaches the two-way one from the consistent start).
    problem.set_guess("motor", lambda t: np.full_like(t, 5.0))
    return problem


@pytest.fixture(scope="module")
def in_process():
    problem = _straight_line_swing_up()
    single = problem.solve(METHOD)
    return single, problem.solve(METHOD, starts=4, seed=0)


def test_multistart_finds_the_better_optimum_and_reports_both(optima, in_process):
    assert optima["two-way"] == pytest.approx(8.913005, abs=1e-6)
    assert optima["one-way"] == pytest.approx(13.670837, abs=1e-6)
    single, best = in_process
    assert single.objective == pytest.approx(optima["one-way"], rel=REL)      # the straight line: one-way
    assert best.success and best.objective <= single.objective
    assert best.objective == pytest.approx(optima["two-way"], rel=REL)
    pos, vel = best.residuals()
    assert pos <= 1e-8 and vel <= 1e-8
    assert len(best.starts) == 4 and all(len(s) == 3 for s in best.starts)
    assert best.starts[0].objective == pytest.approx(single.objective, rel=1e-9)   # start 0: the user's guess
    assert [o["objective"] for o in best.local_optima] == pytest.approx([optima["two-way"], optima["one-way"]], rel=REL)
    assert sum(o["count"] for o in best.local_optima) == best.multistart["succeeded"] == 4
    assert best.multistart["spread"] == pytest.approx(optima["one-way"] - optima["two-way"], rel=1e-3)
    assert best.multistart["best_start"] in best.local_optima[0]["starts"]


@pytest.fixture(scope="module")
def dask_client():
    """A real Dask cluster: two worker processes, one thread each (the starts go to them pickled)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        yield client


def test_dask_local_cluster_gives_the_same_starts_as_in_process(dask_client):
    problem = _straight_line_swing_up()
    local = _straight_line_swing_up().solve(METHOD, starts=2, seed=0)      # the same two starts, in-process
    remote = problem.solve(METHOD, starts=2, seed=0, client=dask_client)    # one start per worker
    assert remote.multistart["executor"].startswith("dask")
    # The same starts (drawn from (seed, k) wherever they run), the same IPOPT: the same optima.
    assert [s.status for s in remote.starts] == [s.status for s in local.starts]
    assert [s.objective for s in remote.starts] == pytest.approx([s.objective for s in local.starts], rel=1e-9)
    assert remote.objective == pytest.approx(local.objective, rel=1e-9)
    assert [o["objective"] for o in remote.local_optima] == pytest.approx([o["objective"] for o in local.local_optima],
                                                                         rel=1e-9)
    # The best start rebuilt here is a whole solution of this problem.
    assert remote.transcription is problem.transcription(METHOD)
    np.testing.assert_allclose(remote.sample("motor"), local.sample("motor"), atol=1e-6)


def test_a_multistart_on_dask_after_a_first_solve_in_maximal_coordinates_ships_the_problem(dask_client):
    """A first solve in maximal coordinates projects its guess onto the constraints and keeps the projection's compiled
    function, buffers and lock on the equations; the problem then goes to the workers pickled. That raised "cannot
    pickle '_thread.lock' object" before session 32. The starts are the in-process ones."""
    problem = _straight_line_swing_up()
    problem.solve(METHOD)
    assert any(k.startswith("_projection") for k in problem.eqs.__dict__)      # what the first solve left there
    local = _straight_line_swing_up().solve(METHOD, starts=2, seed=0)
    remote = problem.solve(METHOD, starts=2, seed=0, client=dask_client)
    assert [s.objective for s in remote.starts] == pytest.approx([s.objective for s in local.starts], rel=1e-9)


def test_perturbations_keep_the_fixed_ends_and_depend_only_on_seed_and_start():
    problem = _straight_line_swing_up()
    t = np.linspace(0.0, 2.0, 11)
    first, again = perturbed_guesses(problem, 2, seed=7), perturbed_guesses(problem, 2, seed=7)
    other = perturbed_guesses(problem, 3, seed=7)
    psi = first["rod.psi"](t)
    assert psi[0] == pytest.approx(0.0, abs=1e-15) and psi[-1] == pytest.approx(math.pi, abs=1e-14)
    np.testing.assert_array_equal(psi, again["rod.psi"](t))
    assert np.abs(psi - other["rod.psi"](t)).max() > 1e-3
    np.testing.assert_array_equal(perturbed_guesses(problem, 0, seed=7)["rod.psi"](t), math.pi * t / 2)
    # A coordinate the guess keeps constant (the hinge holds theta) is not moved.
    np.testing.assert_array_equal(first["rod.theta"](t), 0.0)


def test_clusters_and_bad_arguments():
    clusters = cluster_objectives({0: 1.0, 1: 1.0 + 1e-9, 2: 1.5, 3: 1.0000001}, rtol=1e-5)
    assert [(c["objective"], c["count"]) for c in clusters] == [(1.0, 3), (1.5, 1)]
    problem = _straight_line_swing_up()
    for bad in (0, -2, 2.5):
        with pytest.raises(oc.ModelError, match="starts must be a whole number"):
            problem.solve(METHOD, starts=bad)
    with pytest.raises(oc.ModelError, match="seed must be"):
        problem.solve(METHOD, starts=2, seed=-1)
    with pytest.raises(oc.ModelError, match="Dask client"):
        problem.solve(METHOD, starts=2, client=object())
