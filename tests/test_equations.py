"""System assembly: sparsity is kept, and nothing is built that a scene does not need."""
from __future__ import annotations

import numpy as np

from ocp_constraints import SystemEquations, build_scene


def test_pure_force_joint_has_structurally_zero_moment_outputs():
    eqs = SystemEquations(build_scene("rolling_disk").model)
    sp = eqs.loads_function.sparsity_out(0)
    rows = set(sp.row())
    # Output layout per channel: F (0-2), M (3-5), point (6-8), power (9).
    assert {0, 1, 2} <= rows
    assert not rows & {3, 4, 5}  # M_c = 0 is a structural zero, never computed


def test_constraint_jacobian_keeps_the_block_structure_of_the_chain():
    eqs = SystemEquations(build_scene("ball_socket").model)
    G = eqs.G.sparsity()
    assert G.shape == (6, 12)  # socket_O.v1-3, socket_C.v1-3; u = (vbar1, omega1, vbar2, omega2)
    pattern = np.zeros(G.shape, dtype=bool)
    pattern[G.row(), G.get_col()] = True
    # Row k of a ball-and-socket is d(E_k . v_P)/du with v_P = vbar + omega x r: E_k on vbar,
    # r x E_k on omega (no k-th component, whatever r). socket_O (rows 0-2) holds body 1 only;
    # socket_C (rows 3-5) gives body 1 the +, body 2 the - of the same pattern.
    expected = np.zeros((6, 12), dtype=bool)
    for k in range(3):
        across = np.arange(3) != k
        expected[k, k] = expected[3 + k, k] = expected[3 + k, 6 + k] = True
        expected[k, 3:6] = expected[3 + k, 3:6] = expected[3 + k, 9:12] = across
    assert (pattern == expected).all(), pattern.astype(int)
    # Mass matrix: m I (diagonal) and Q J Q^T (full 3 x 3) per body, no coupling between bodies.
    M = eqs.mass_matrix.sparsity()
    assert M.shape == (12, 12)
    mpat = np.zeros(M.shape, dtype=bool)
    mpat[M.row(), M.get_col()] = True
    body = np.zeros((6, 6), dtype=bool)
    body[0:3, 0:3] = np.eye(3, dtype=bool)
    body[3:6, 3:6] = True
    assert (mpat == np.kron(np.eye(2, dtype=bool), body)).all(), mpat.astype(int)


def test_loads_are_not_built_unless_asked_for():
    eqs = SystemEquations(build_scene("whirling").model)
    assert "loads_function" not in eqs.__dict__ and "forward_dynamics" not in eqs.__dict__
