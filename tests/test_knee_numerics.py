"""The knee's NumPy shortcuts against a second derivation: moment arms written out by hand
(:meth:`MusclePaths.moment_arms_at`) against CasADi's automatic differentiation of the same
fitted polynomials, and the sparse block-diagonal balance matrix against a dense assembly."""
import casadi as ca
import numpy as np

from ocp_constraints.biomech.knee_muscles import MusclePaths
from ocp_constraints.biomech.knee_static import _block_diagonal


def test_hand_written_moment_arms_equal_automatic_differentiation_of_the_fits():
    paths = MusclePaths()
    rng = np.random.default_rng(3)
    Q = np.array([paths.q_vector({}) for _ in range(7)])
    for i, c in enumerate(paths.coordinates):           # poses spread over the gait range
        Q[:, i] += rng.uniform(-0.6, 0.6, len(Q)) * (0.004 if c.startswith("knee_t") else 1.0)
    R = paths.moment_arms_at(Q)
    for n, q in enumerate(Q):
        ad = np.asarray(paths.moment_arms(q)).T          # coordinates x muscles, by CasADi's AD
        np.testing.assert_allclose(R[n], ad, rtol=0, atol=1e-12)
    assert np.abs(R).max() > 0.05                       # not trivially zero: real moment arms (m)


def test_sparse_block_diagonal_equals_the_dense_matrix():
    rng = np.random.default_rng(4)
    blocks = rng.normal(size=(5, 3, 4))
    blocks[blocks < 0.2] = 0.0                           # structural zeros in every block
    dense = np.zeros((15, 20))
    for k, b in enumerate(blocks):
        dense[3 * k:3 * k + 3, 4 * k:4 * k + 4] = b
    B = _block_diagonal(blocks)
    assert B.nnz() == np.count_nonzero(dense)
    np.testing.assert_array_equal(np.asarray(ca.DM(B).full()), dense)

