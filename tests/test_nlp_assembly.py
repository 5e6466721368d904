"""The assembled NLP derivatives against CasADi's own AD of the same NLP graph.

nlp_assembly differentiates each element on its own and scatters the pieces; CasADi's
``jacobian``/``hessian`` of the whole MX graph is an independent derivation of the
same quantities, so the two must agree to rounding.
"""
import casadi as ca
import numpy as np
import pytest

from ocp_constraints.ocp.transcription import Transcription
from ocp_constraints.ocp.nlp_assembly import BlockNLP, element
from ocp_constraints.scenes.registry import build_task
from ocp_constraints.ocp.schemes import HermiteSimpson, Radau, Trapezoidal


def _whole_graph_derivatives(nlp: BlockNLP):
    w, f, g = nlp.w, nlp.f, nlp.g
    grad = ca.Function("reference_grad", [w], [ca.gradient(f, w)])
    jac = ca.Function("reference_jac", [w], [ca.jacobian(g, w)])
    hess = ca.Function("reference_hess", [w, nlp.lam_f, nlp.lam_g], [ca.triu(ca.hessian(nlp.lam_f * f + ca.dot(nlp.lam_g, g), w)[0])])
    return grad, jac, hess


def _assert_derivatives_agree(nlp: BlockNLP, x: np.ndarray, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    lam_g, lam_f = rng.standard_normal(nlp.m), 0.7
    grad, jac, hess = _whole_graph_derivatives(nlp)
    pairs = [(grad(x), nlp.grad_f(x, [])[1]), (jac(x), nlp.jac_g(x, [])[1]),
             (hess(x, lam_f, lam_g), nlp.hess_lag(x, [], lam_f, lam_g))]
    for reference, assembled in pairs:
        reference, assembled = np.array(ca.densify(reference)), np.array(ca.densify(assembled))
        scale = max(1.0, np.abs(reference).max())
        assert np.abs(reference - assembled).max() <= 1e-12 * scale


def test_shared_and_repeated_variables_add_up_and_fixed_zeros_drop_out():
    z, c = ca.SX.sym("z", 3), ca.SX.sym("c")
    # Instances share variables 2 and 4; the last instance reads a fixed zero (-1).
    chain = element("chain", z, c, ca.vertcat(z[0] * z[1] * c, ca.sin(z[2]) + z[0] ** 2), z[1] ** 2 * z[2] * c,
                    [[0, 1, 2], [2, 3, 4], [4, 5, -1]], [[1.0], [2.0], [3.0]])
    y = ca.SX.sym("y", 2)
    bounded = element("bounded", y, ca.SX.sym("none", 0), ca.exp(y[0]) * y[1], y[0] ** 3, [[0, 5]], np.zeros((1, 0)), -1.0, 1.0)
    # One instance reading variable 1 twice: chain rule sums, Hessian diagonal counts both ways.
    repeated = element("repeated", z, c, z[0] * z[1] * z[2] + c, z[0] ** 2 * z[2] + ca.sin(z[0] * z[1]) * c,
                       [[1, 3, 1]], [[0.5]])
    nlp = BlockNLP(6, [chain, bounded, repeated])
    assert nlp.m == 8 and nlp.rows("bounded") == 6
    assert list(nlp.lbg) == [0.0] * 6 + [-1.0, 0.0] and list(nlp.ubg) == [0.0] * 6 + [1.0, 0.0]
    _assert_derivatives_agree(nlp, np.random.default_rng(1).standard_normal(6))


@pytest.mark.parametrize("task, scheme", [
    (("pendulum", "swing_up"), Trapezoidal(4)),
    (("pendulum", "swing_up"), HermiteSimpson(3)),
    (("pendulum", "swing_up"), Radau(3, degree=3)),
    (("pendulum", "swing_up"), Radau(2, degree=6)),       # accelerations stay variables
    (("whirling", "spin_up"), Radau(3, degree=2)),      # inputs inside constraints, extrapolated at t0
    (("rolling_disk", "drive"), HermiteSimpson(3)),     # friction-cone path constraints
    ("min_time", Radau(3, degree=2)),                   # free final time in every element
])
def test_transcription_derivatives_match_whole_graph_ad(task, scheme, request):
    if task == "min_time":
        _, problem = request.getfixturevalue("ocp_minimum_time_swing_up")
        problem.minimize_effort(weight=0.1)  # a cost term besides the final time
    else:
        problem = build_task(*task)[1]
    tr = Transcription(problem, scheme)
    x = tr.initial_guess()
    x = x + 0.1 * np.random.default_rng(2).standard_normal(x.size)  # away from the guess's symmetries
    _assert_derivatives_agree(tr.block, x)
