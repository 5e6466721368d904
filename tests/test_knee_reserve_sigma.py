"""Reserves weighted by the inverse dynamics' uncertainty (issue 15, candidate C18; knee_static).

The static problem with reserve weights ``w_c = 1/(2 sigma_c^2)`` is checked against closed forms on a small
problem whose activation bounds and contact signs are inactive, so that it is an equality-constrained
least-squares problem: per frame ``min |a|^2 + (q - M a)^T W (q - M a)``, ``a = (I + M^T W M)^-1 M^T W q``
(the MAP estimate under the Gaussian likelihood of ``q`` and the effort prior), and as ``sigma -> 0`` the
exact balance's minimum-norm solution ``a = M^T (M M^T)^-1 q`` (the pseudo-inverse). No trial data.
"""
from __future__ import annotations

import numpy as np
import pytest

from ocp_constraints.biomech.knee_static import RESERVED, reserve_weights_from_sigma, solve_static
from ocp_constraints.errors import KneeError

HIP = ["hip_flexion", "hip_adduction", "hip_rotation"]


def _problem(seed: int = 0):
    """3 frames, 5 muscles crossing only the hip (arms 1-6 cm, F0 300-700 N), each of the five knee multipliers
    balancing one locked-knee row alone with a positive load (medial, lateral 300 N). The hip demand is ``M a0``
    with ``a0 = M^T y`` in (0, 0.5]: in the row space of ``M``, so the exact balance's minimum-norm activations are
    interior (``a0`` itself)."""
    rng = np.random.default_rng(seed)
    N, nm, nr = 3, 5, len(RESERVED) + 5
    R = np.zeros((N, nr, nm))
    R[:, :3, :] = rng.uniform(0.01, 0.06, (N, 3, nm))
    F0 = rng.uniform(300.0, 700.0, nm)
    A = np.zeros((N, 5, nr))
    for j in range(5):
        A[:, j, len(RESERVED) + j] = 1.0
    Q = np.zeros((N, nr))
    for k in range(N):
        M = R[k, :3, :] * F0
        a0 = M.T @ rng.uniform(0.5, 1.0, 3)
        Q[k, :3] = M @ (0.5 * a0 / a0.max())
    Q[:, len(RESERVED):len(RESERVED) + 2] = 300.0
    return np.arange(N) * 0.01, Q, R, A, F0


def _closed_form(Q, R, F0, w):
    """Per frame: activations and hip reserves of min |a|^2 + sum_c w_c rho_c^2, M a + rho = q."""
    acts, res = [], []
    for k in range(Q.shape[0]):
        M = R[k, :3, :] * F0
        W = np.diag(w[:3])
        a = np.linalg.solve(np.eye(M.shape[1]) + M.T @ W @ M, M.T @ W @ Q[k, :3])
        acts.append(a)
        res.append(Q[k, :3] - M @ a)
    return np.array(acts), np.array(res)


def test_weight_is_the_gaussian_likelihoods_inverse_variance_over_two():
    w = reserve_weights_from_sigma({"hip_rotation": 2.0, "hip_flexion": 0.5})
    assert w[RESERVED.index("hip_rotation")] == pytest.approx(1.0 / 8.0)
    assert w[RESERVED.index("hip_flexion")] == pytest.approx(2.0)
    others = [i for i, c in enumerate(RESERVED) if c not in ("hip_rotation", "hip_flexion")]
    assert np.all(w[others] == 1.0)


def test_direction_dependent_sigma_gives_the_map_estimate_of_the_closed_form():
    t, Q, R, A, F0 = _problem()
    w = reserve_weights_from_sigma({"hip_flexion": 1.0, "hip_adduction": 2.0, "hip_rotation": 6.0})
    a_ref, rho_ref = _closed_form(Q, R, F0, w)
    assert np.all((a_ref > 0.0) & (a_ref < 1.0)), "bounds must be inactive for the closed form to be the optimum"
    res = solve_static(t, Q, R, A, F0, reserve_weight=w)
    assert np.allclose(res.activation, a_ref, atol=1e-6)
    assert np.allclose(res.reserve[:, :3], rho_ref, atol=1e-5)
    # the dearest balance (smallest sigma) keeps the smallest share of its demand as reserve
    share = np.abs(rho_ref / Q[:, :3])
    assert np.all(share[:, 0] < share[:, 2])
    # the cost the solver minimised is the stated Gaussian form: no other activations do better
    cost = lambda a, rho: np.sum(a ** 2) + np.sum(w[:3] * rho ** 2)   # noqa: E731
    assert cost(res.activation, res.reserve[:, :3]) <= cost(a_ref, rho_ref) + 1e-8


def test_sigma_to_zero_gives_the_exact_balance():
    t, Q, R, A, F0 = _problem(seed=1)
    w = reserve_weights_from_sigma({c: 1e-3 for c in HIP})
    res = solve_static(t, Q, R, A, F0, reserve_weight=w)
    for k in range(len(t)):
        M = R[k, :3, :] * F0
        a_exact = M.T @ np.linalg.solve(M @ M.T, Q[k, :3])   # minimum-norm solution of M a = q
        assert np.all((a_exact > 0.0) & (a_exact < 1.0))
        assert np.allclose(res.activation[k], a_exact, atol=1e-5)
    assert np.abs(res.reserve[:, :3]).max() < 1e-3


def test_one_weight_per_row_of_ones_equals_the_uniform_default():
    t, Q, R, A, F0 = _problem(seed=2)
    uniform = solve_static(t, Q, R, A, F0)
    rows = solve_static(t, Q, R, A, F0, reserve_weight=reserve_weights_from_sigma({}))
    assert np.allclose(uniform.activation, rows.activation, atol=1e-9)
    assert np.allclose(uniform.reserve, rows.reserve, atol=1e-9)


@pytest.mark.parametrize("sigma, word", [({"knee_tx": 1.0}, "knee_tx"), ({"hip_rotation": 0.0}, "hip_rotation"),
                                         ({"hip_rotation": float("nan")}, "hip_rotation")])
def test_bad_sigma_is_refused_naming_the_coordinate(sigma, word):
    with pytest.raises(KneeError, match=word):
        reserve_weights_from_sigma(sigma)


def test_wrong_number_of_weights_is_refused():
    t, Q, R, A, F0 = _problem()
    with pytest.raises(KneeError, match="reserve_weight"):
        solve_static(t, Q, R, A, F0, reserve_weight=[1.0, 2.0])


def test_per_frame_weights_give_each_frames_map_estimate():
    """Issue 15, C19: one weight per frame and row (frames x RESERVED); each frame is its own closed form."""
    t, Q, R, A, F0 = _problem(seed=3)
    W = np.ones((len(t), len(RESERVED)))
    W[:, :3] = [[2.0, 0.1, 0.5], [0.02, 1.0, 4.0], [0.3, 0.3, 0.3]]
    res = solve_static(t, Q, R, A, F0, reserve_weight=W)
    for k in range(len(t)):
        a_ref, rho_ref = _closed_form(Q[k:k + 1], R[k:k + 1], F0, W[k])
        assert np.all((a_ref > 0.0) & (a_ref < 1.0))
        assert np.allclose(res.activation[k], a_ref[0], atol=1e-6)
        assert np.allclose(res.reserve[k, :3], rho_ref[0], atol=1e-5)


def test_per_frame_weights_of_ones_are_todays_collocation_problem():
    from ocp_constraints.biomech.knee_collocation import solve_collocation

    t, Q, R, A, F0 = _problem(seed=4)
    uniform = solve_collocation(t, Q, R, A, F0)
    frames = solve_collocation(t, Q, R, A, F0, reserve_weight=np.ones((len(t), len(RESERVED))))
    assert uniform.iterations == frames.iterations
    assert np.array_equal(uniform.activation, frames.activation)
    assert np.array_equal(uniform.reserve, frames.reserve)


def test_per_frame_weights_of_the_wrong_shape_are_refused():
    t, Q, R, A, F0 = _problem()
    with pytest.raises(KneeError, match="per frame|one per frame"):
        solve_static(t, Q, R, A, F0, reserve_weight=np.ones((len(t) + 1, len(RESERVED))))
