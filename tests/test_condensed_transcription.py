"""The condensed maximal transcription (coordinates="condensed"): accelerations and multipliers from each
point's KKT system instead of NLP variables (ocp/condensed_transcription.py, issue 13 item 1b).

Independent checks: with slacks at every point the condensed NLP is the maximal NLP with its
accelerations and multipliers eliminated, so both must reach the same optimum (objective, states and
every multiplier) on the same mesh; the pointwise KKT solution is checked against the library's
numerical forward dynamics (a sparse numerical QR of the same system, no symbolic elimination); the
mesh-slack default is a different discretization of the same DAE and must converge to the
Pontryagin optimum of the swing-up (bench/references.py) as the mesh is refined.
"""
import math

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.bench import ocp_suite_3d as spatial
from ocp_constraints.bench.ocp_suite_params import DISK
from ocp_constraints.bench.references import swing_up_reference
from ocp_constraints.errors import ModelError
from ocp_constraints.ocp.condensed_kkt import pointwise_kkt
from ocp_constraints.ocp.condensed_transcription import CondensedTranscription
from ocp_constraints.ocp.transcription import Transcription

E = [ca.DM.eye(3)[:, k] for k in range(3)]


def hand_hinge_swing_up(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """The pendulum swing-up (problems/pendulum.py, planar rod) with the hinge written by hand."""
    model = oc.Model("pendulum", gravity=(0.0, -9.81, 0.0))
    d = np.array([0.0, -1.0, 0.0])
    rod = model.add_body("rod", 1.0, 1.0 / 12 * (np.eye(3) - np.outer(d, d)), rotation="321")
    A = rod.point("A", -0.5 * d)
    for k in range(3):
        model.add_constraint(f"hinge.v{k + 1}", ca.dot(E[k], A.v), joint="hinge", position=A.position[k])
    for k in range(2):
        model.add_constraint(f"hinge.w{k + 1}", ca.dot(E[k], rod.omega), joint="hinge")
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    ocp = oc.OptimalControlProblem(model, t_final=2.0, coordinates=coordinates)
    ocp.bound("motor", -20.0, 20.0)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0, "rod.theta": 0.0, "rod.phi": 0.0})
    ocp.final({"rod.psi": math.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    ocp.set_guess("rod.psi", lambda t: math.pi * t / 2 - np.sin(math.pi * t / 2))
    return ocp


def test_pointwise_kkt_equals_the_numerical_forward_dynamics():
    rng = np.random.default_rng(3)
    for problem in (hand_hinge_swing_up(), spatial.rolling_disk(), spatial.quadrotor_load()):
        e = problem.eqs
        k = pointwise_kkt(e)
        f = ca.Function("kkt", [e.q, e.u, e.t, e.inputs], [k.a, k.lam, k.da, k.dlam])
        q, u, w = rng.uniform(-0.6, 0.6, e.nq), rng.uniform(-1, 1, e.nu), rng.uniform(-1, 1, e.inputs.numel())
        a, lam, da, dlam = (np.asarray(v) for v in f(q, u, 0.3, w))
        a_ref, lam_ref = (np.asarray(v).ravel() for v in e.forward_dynamics(q, u, 0.3, w, np.zeros(e.inputs.numel())))
        assert np.allclose(a.ravel(), a_ref, rtol=0, atol=1e-10 * max(1, np.abs(a_ref).max()))
        assert np.allclose(lam.ravel(), lam_ref, rtol=0, atol=1e-10 * max(1, np.abs(lam_ref).max()))
        # The slack keeps the balance M u' = f + G^T lambda (it only frees the acceleration level).
        M = np.asarray(e.mass_matrix_function(q))
        G = np.asarray(e.constraint_functions(q, u, 0.3, w)[0])
        assert np.allclose(M @ da, G.T @ dlam, rtol=0, atol=1e-10)
        assert np.linalg.matrix_rank(da) == e.nc


def test_slacks_at_every_point_reach_the_maximal_optimum_with_the_same_multipliers():
    problem = hand_hinge_swing_up()
    method = oc.Radau(8, degree=3)
    maximal = Transcription(problem, method).solve({})
    condensed = CondensedTranscription(problem, method, slacks="points").solve({})
    assert condensed.objective == pytest.approx(maximal.objective, rel=1e-9)
    assert np.allclose(condensed.X, maximal.X, rtol=0, atol=1e-7)
    scale = np.abs(maximal.lam).max()
    assert np.allclose(condensed.lam, maximal.lam, rtol=0, atol=1e-7 * scale)
    assert np.allclose(condensed.D, maximal.D, rtol=0, atol=1e-6)
    for name in ("hinge.F_x", "hinge.F_y", "hinge.M_x", "hinge.power"):
        assert np.allclose(condensed.loads()[name], maximal.loads()[name], rtol=0, atol=1e-7 * scale)


def test_mesh_slacks_converge_to_the_pontryagin_optimum_and_hold_the_constraints_at_mesh_points():
    # The hand-written hinge is the scene's revolute joint: the swing-up's optimum is the Pontryagin
    # extremal of bench/references.py (shooting on the 1-DOF equation, no collocation, no library code).
    optimum = swing_up_reference().objective
    errors = {}
    for N in (16, 32):
        method = oc.Radau(N, degree=3)
        problem = hand_hinge_swing_up("condensed")
        sol = problem.solve(method)
        tr = problem.transcription(method)
        assert isinstance(tr, CondensedTranscription) and sol.success
        # phi = 0 and G u + e = 0 are rows at t0 and at every interval end.
        ends = [0, *tr.layout.slack_points]
        _, _, phi, pi, _ = problem.eqs.constraint_functions.map(len(ends))(
            sol.X[:6, ends], sol.X[6:, ends], sol.t[None, ends], sol.inputs[:, ends])
        assert np.abs(np.asarray(phi)).max() < 1e-9 and np.abs(np.asarray(pi)).max() < 1e-9
        errors[N] = abs(sol.objective - optimum)
    maximal = abs(Transcription(hand_hinge_swing_up(), oc.Radau(16, degree=3)).solve({}).objective - optimum)
    assert errors[16] < 1e-3 and errors[16] < maximal      # measured: 3.0e-4 against the maximal form's 3.5e-3
    # Radau 3 converges at order 5 at the mesh points: halving h must shrink the error far more than 8x.
    assert errors[32] < errors[16] / 8


def test_a_friction_cone_on_condensed_multipliers_holds_and_shapes_the_same_optimum():
    # The cone is a path row on lambda_KKT + dlam s at every point (the same point element for both
    # slack placements); with slacks at every point the optimum must be the maximal form's.
    method = oc.Radau(6, degree=3)
    sol = CondensedTranscription(spatial.rolling_disk(), method, slacks="points").solve({})
    maximal = Transcription(spatial.rolling_disk(), method).solve({})
    F = np.column_stack([sol.loads()[f"contact.F_{a}"] for a in "xyz"])
    mu = DISK["mu"]
    assert F[:, 2].min() >= -1e-8
    assert (np.hypot(F[:, 0], F[:, 1]) <= mu * F[:, 2] + 1e-8).all()
    # The cone is active somewhere on this task: the bound shapes the optimum.
    assert (np.hypot(F[:, 0], F[:, 1]) >= mu * F[:, 2] - 1e-6).any()
    assert sol.objective == pytest.approx(maximal.objective, rel=1e-9)
    F_max = np.column_stack([maximal.loads()[f"contact.F_{a}"] for a in "xyz"])
    assert np.allclose(F, F_max, rtol=0, atol=1e-7 * np.abs(F_max).max())


def test_an_input_inside_a_constraint_is_refused_by_name():
    model = oc.Model("driven")
    body = model.add_body("body", 1.0, np.eye(3) * 0.1)
    w = model.add_input("omega")
    model.add_constraint("drive", body.omega[2] - w)
    with pytest.raises(ModelError, match="drive"):
        pointwise_kkt(oc.OptimalControlProblem(model).eqs)
