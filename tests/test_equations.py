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
    dense = np.array(eqs.G.sparsity().full()) if hasattr(G, "full") else None
    pattern = np.zeros(G.shape, dtype=bool)
    pattern[G.row(), G.get_col()] = True
    # socket_O (rows 0-2) acts on body 1 only (columns 0-5); socket_C on both.
    assert not pattern[0:3, 6:12].any()
    assert pattern[3:6, 0:12].any(axis=0).all() or pattern[3:6, 6:12].any()
    # Mass matrix: m I and Q J Q^T blocks, no coupling between bodies.
    M = eqs.mass_matrix.sparsity()
    mpat = np.zeros(M.shape, dtype=bool)
    mpat[M.row(), M.get_col()] = True
    assert not mpat[0:6, 6:12].any() and not mpat[0:3, 3:6].any()
    assert dense is None or dense.shape == G.shape


def test_loads_are_not_built_unless_asked_for():
    eqs = SystemEquations(build_scene("whirling").model)
    assert "loads_function" not in eqs.__dict__ and "forward_dynamics" not in eqs.__dict__
