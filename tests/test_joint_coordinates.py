"""Optimal control in joint coordinates (``coordinates="joint"``, paper sec. 5, eqs. 34-44).

Checked against independent values: the swing-up's Pontryagin extremal (objective and hinge
loads, bench/references.py: shooting on the 1-DOF equation, hinge loads by a hand balance);
the maximal KKT system (``SystemEquations.forward_dynamics``: accelerations and every
multiplier of a three-body chain from the bodies' Newton-Euler balances, a different
derivation from the joint-coordinate projection and the leaf-to-root recovery); the maximal
transcription of the same problem; Euler angles against the rotation they were built from.
"""
from __future__ import annotations

import numpy as np
import casadi as ca
import pytest

import ocp_constraints as oc
from ocp_constraints.bench.references import swing_up_reference
from ocp_constraints.errors import ModelError
from ocp_constraints.mechanics.generalized import JointCoordinates, euler_from_rotation
from ocp_constraints.mechanics.rotations import EulerSequence
from ocp_constraints.ocp.joint_transcription import JointTranscription


def _swing_up(coordinates: str):
    _, ocp = oc.build_task("pendulum", "swing_up")
    ocp.coordinates = coordinates
    return ocp


@pytest.fixture(scope="module")
def reference():
    return swing_up_reference()


@pytest.fixture(scope="module")
def joint50():
    sol = _swing_up("joint").solve(oc.Radau(50, degree=3))
    assert sol.success, sol.status
    return sol


def test_euler_angles_from_a_rotation_give_it_back_for_every_sequence():
    rng = np.random.default_rng(3)
    a = ca.SX.sym("a", 3)
    for axes in ("123", "132", "213", "231", "312", "321", "121", "131", "212", "232", "313", "323"):
        seq = EulerSequence(axes)
        angles = rng.uniform(-3.0, 3.0, 3)
        angles[1] = rng.uniform(0.2, 2.9) if seq.is_proper else rng.uniform(-1.4, 1.4)
        Q = ca.Function("Q", [a], [seq.rotation(a)])(angles)
        back = np.array([float(ca.evalf(v)) for v in euler_from_rotation(axes, ca.SX(Q))])
        assert np.allclose(back, angles, atol=1e-12), (axes, back, angles)


def test_swing_up_in_joint_coordinates_reaches_the_pontryagin_optimum(joint50, reference):
    # Same scheme and mesh as the maximal form's README row (Radau 3, N = 50): objective error
    # O(h^5); measured 8.913005895 against the extremal's 8.913005 (the maximal form: 8.9130176).
    assert abs(joint50.objective - reference.objective) <= 5e-6
    psi, psi_dot = reference.states(joint50.t)
    assert np.abs(joint50.sample("rod.psi") - psi).max() <= 1e-4
    assert np.abs(joint50.sample("rod.psi_dot") - psi_dot).max() <= 1e-3
    assert joint50.sample("rod.psi")[-1] == pytest.approx(np.pi, abs=1e-9)


def test_hinge_loads_by_name_match_the_pontryagin_reference(joint50, reference):
    # The hinge's multipliers are not NLP variables here: they come from the rod's balance.
    # Measured max errors over every point, Radau 3, N = 50: 2.4e-4 N (v1) and 3.5e-4 N (v2) here;
    # the maximal transcription's on the same mesh: 7.3e-3 and 9.6e-3 N (its multipliers are
    # variables of an index-2 DAE). Bound 1e-3 N, 4e-5 of the largest load (25.15 N).
    ref = reference.multipliers(joint50.t)
    for k in ("hinge.v1.lambda", "hinge.v2.lambda"):
        assert np.abs(joint50.sample(k) - ref[k]).max() <= 1e-3, k
    scale = 25.15
    for k in ("hinge.v3.lambda", "hinge.w1.lambda", "hinge.w2.lambda"):
        assert np.abs(joint50.sample(k)).max() <= 1e-9 * scale
    loads = joint50.loads()
    assert np.allclose(loads["hinge.F_y"], joint50.sample("hinge.v2.lambda"))
    # Power of the hinge load: zero for a fixed hinge (eq. 27, -lambda e with e = 0).
    assert np.abs(loads["hinge.power"]).max() <= 1e-9


def test_multipliers_of_a_joint_chain_match_the_maximal_kkt_system():
    # Three bodies: a tilted revolute to ground, a revolute between bodies, a prismatic between
    # bodies, plus a contact written by hand (it stays a constraint with its multiplier).
    model = oc.Model("chain", gravity=(0.0, 0.0, -9.81))
    J = np.diag([0.02, 0.03, 0.04])
    a = model.add_body("a", 1.0, J, rotation="321")
    b = model.add_body("b", 0.7, J, rotation="321")
    c = model.add_body("c", 0.4, J * 0.5, rotation="123")
    oc.joints.revolute(model, "hip", a.point("top", (0.0, 0.0, 0.3)), axis=(0.2, 0.1, 1.0), anchor=(0.1, 0.0, 1.0))
    oc.joints.revolute(model, "knee", b.point("top", (0.0, 0.1, 0.2)), axis=(0, 1, 0), other=a.point("end", (0.1, 0, -0.3)))
    oc.joints.prismatic(model, "slide", c.point("p", (0.05, 0, 0)), axis=(1, 0, 0), other=b.point("end", (0, 0, -0.2)))
    model.add_torque("motor", a, ca.vertcat(0, 0, model.add_input("tau")))
    # A drive written by hand in the knee's group (a prescribed relative rate): not the revolute
    # function's, so it stays a constraint with its multiplier (the drive torque).
    model.add_constraint("knee.drive", ca.dot(b.omega - a.omega, a.Q @ ca.DM([0, 1, 0])) - 0.3 * ca.sin(model.t),
                         joint="knee")
    eqs = oc.SystemEquations(model)
    r = JointCoordinates(eqs)
    assert r.coordinate_names == ["hip.angle", "knee.angle", "slide.distance"] and r.constraint_names == ["knee.drive"]
    rng = np.random.default_rng(7)
    p, ur, w, t = rng.uniform(-1, 1, 3), rng.uniform(-2, 2, 3), np.array([0.8]), 0.4
    ur[1] = 0.3 * np.sin(t)                 # on the drive's constraint
    parts = ca.Function("kkt", [r.q, r.u, r.t, r.inputs], [r.mass_matrix, r.forces, r.G, r.gamma])
    Mr, fr, Gr, gr = (np.asarray(v) for v in parts(p, ur, t, w))
    K = np.block([[Mr, -Gr.T], [Gr, np.zeros((1, 1))]])
    z = np.linalg.solve(K, np.concatenate([fr.ravel(), -gr.ravel()]))
    q, u, udot, lam = (np.asarray(v).ravel() for v in r.maximal_function(p, ur, z[:3], z[3:], w, t))
    _, _, phi, pi, _ = eqs.constraint_functions(q, u, t, w)
    assert np.abs(np.asarray(phi)).max() <= 1e-14 and np.abs(np.asarray(pi)).max() <= 1e-13
    udot_kkt, lam_kkt = (np.asarray(v).ravel() for v in eqs.forward_dynamics(q, u, t, w, 0.0))
    assert np.allclose(udot, udot_kkt, atol=1e-10) and np.allclose(lam, lam_kkt, atol=1e-9 * np.abs(lam_kkt).max())


def test_a_hinge_written_by_hand_stays_a_constraint_and_gives_the_same_optimum():
    # The pendulum's hinge as plain constraints (E_k . v_A = 0, E1/E2 . omega = 0): no joint map,
    # so joint coordinates leave the rod's six coordinates and the five multipliers as they are.
    _, library = oc.build_task("pendulum", "swing_up")
    library.coordinates = "maximal"
    model = oc.Model("by_hand", gravity=(0.0, -9.81, 0.0))
    rod = model.add_body("rod", 1.0, np.diag([1 / 12, 0.0, 1 / 12]), rotation="321")
    A = rod.point("A", (0.0, 0.5, 0.0))
    for k in range(3):
        model.add_constraint(f"hinge.v{k + 1}", A.v[k], joint="hinge", position=A.position[k])
    model.add_constraint("hinge.w1", rod.omega[0], joint="hinge", position=rod.rotation_parameters[2])
    model.add_constraint("hinge.w2", rod.omega[1], joint="hinge", position=rod.rotation_parameters[1])
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    ocp = oc.OptimalControlProblem(model, t_final=2.0, coordinates="joint")
    ocp.bound("motor", -20.0, 20.0)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi": np.pi, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    ocp.set_guess("rod.psi", library.guess["rod.psi"])
    tr = ocp.transcription(oc.Radau(10, degree=3))
    assert not isinstance(tr, JointTranscription)          # nothing to reduce: the maximal NLP itself
    by_hand = ocp.solve(oc.Radau(10, degree=3))
    maximal = library.solve(oc.Radau(10, degree=3))      # joints.revolute, maximal coordinates
    assert by_hand.objective == pytest.approx(maximal.objective, rel=1e-9)
    assert np.allclose(by_hand.sample("hinge.v2.lambda"), maximal.sample("hinge.v2.lambda"), atol=1e-7)


def test_warm_starts_cross_between_maximal_and_joint_coordinates(joint50):
    warm = _swing_up("maximal").solve(oc.Radau(10, degree=3), warm_start=joint50)
    back = _swing_up("joint").solve(oc.Radau(20, degree=3), warm_start=warm)
    cold = _swing_up("joint").solve(oc.Radau(20, degree=3))
    assert warm.success and back.success
    # The maximal form's optimum on its mesh (N = 10: 8.9479) is another discretization; from it the
    # joint NLP goes to its own optimum, the one it reaches from its own guess.
    assert back.objective == pytest.approx(cold.objective, rel=1e-9)
    assert back.iterations <= cold.iterations


def test_a_bound_on_a_hinge_load_is_active_in_joint_coordinates():
    # A load bound needs the hinge multiplier inside the NLP: here an expression of the state and
    # of the reduced dynamics. Bounding the hinge force along E1 to 8 N (free optimum: ~11 N)
    # raises the effort; the maximal transcription of the same problem agrees.
    out = {}
    for coordinates in ("maximal", "joint"):
        ocp = _swing_up(coordinates)
        ocp.subject_to(ocp.joint_force("hinge")[0], -8.0, 8.0, "hinge force x")
        out[coordinates] = ocp.solve(oc.Radau(20, degree=3))
    assert np.abs(out["joint"].sample("hinge.v1.lambda")).max() == pytest.approx(8.0, abs=1e-6)
    # The two forms are different discretizations: at N = 20 their unconstrained optima differ by
    # 1.2e-4 (relative; 8.91418 maximal, 8.91307 joint, 8.91301 Pontryagin).
    assert out["joint"].objective == pytest.approx(out["maximal"].objective, rel=3e-4)
    assert out["joint"].objective > 8.92


def test_unknown_coordinates_are_refused_by_name():
    model = oc.Model("m")
    model.add_body("b", 1.0, np.eye(3) * 0.1)
    with pytest.raises(ModelError, match="coordinates must be one of auto, maximal, joint"):
        oc.OptimalControlProblem(model, coordinates="minimal")


def test_the_solve_command_takes_joint_coordinates_and_writes_the_bodies_results(tmp_path, reference):
    import json

    from ocp_constraints.cli.main import main

    assert main(["solve", "pendulum", "--coordinates", "joint", "--intervals", "20", "--out", str(tmp_path),
                 "--no-plots"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["solver"]["coordinates"] == "joint"
    assert abs(summary["objective"] - reference.objective) <= 1e-4      # Radau 3, N = 20: 6.4e-5 measured
    assert summary["constraints"] == ["hinge.v1", "hinge.v2", "hinge.v3", "hinge.w1", "hinge.w2"]
    header = (tmp_path / "loads.csv").read_text().splitlines()[0].split(",")
    assert "hinge.v2.lambda" in header and "hinge.F_y" in header
    assert max(summary["max_constraint_residual"].values()) <= 1e-12


def test_an_imported_robot_moves_in_its_urdf_joint_angles(tmp_path):
    # URDF links are quaternion bodies: placed by the composed unit quaternion. The joint
    # coordinates are the URDF's joint angles, checked against the importer's own forward
    # kinematics (robot.body_states, mechanics/urdf_robot.py), a separate derivation.
    pytest.importorskip("yourdfpy", reason="the URDF parser is the optional extra 'urdf'")
    link = ('<link name="{0}"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/><inertia ixx="0.02" iyy="0.02" '
            'izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    joint = ('<joint name="{0}" type="revolute"><parent link="{1}"/><child link="{2}"/><origin xyz="{3}"/>'
             '<axis xyz="{4}"/><limit effort="30" lower="-3" upper="3" velocity="10"/></joint>')
    path = tmp_path / "arm.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="arm"><link name="world"/>' + link.format("l1") + link.format("l2")
                    + joint.format("j1", "world", "l1", "0 0 1", "0 1 0") + joint.format("j2", "l1", "l2", "0 0 -0.5", "1 0 1")
                    + "</robot>\n")
    robot = oc.load_urdf(path)
    r = JointCoordinates(oc.SystemEquations(robot.model))
    assert r.coordinate_names == ["j1.angle", "j2.angle"] and r.nc == 0
    q, qd, qdd = np.array([[0.7, -2.4]]), np.array([[0.3, 1.1]]), np.array([[0.2, -0.5]])
    expected = robot.body_states(q, qd, qdd)
    got = r.maximal_function(q.ravel(), qd.ravel(), qdd.ravel(), [], [0.0, 0.0], 0.0)[:3]
    for a, b in zip(got, expected):
        assert np.allclose(np.asarray(a).ravel(), np.asarray(b).ravel(), atol=1e-14)
    # Rest to rest, then with the first joint's force bounded below the free optimum's peak: active.
    qa, qb = np.array([0.0, 0.0]), np.array([1.0, -0.5])

    def solve(bound):
        problem = oc.OptimalControlProblem(robot.model, t_final=1.0, coordinates="joint")
        robot.set_boundary(problem, "initial", qa)
        robot.set_boundary(problem, "final", qb)
        robot.set_guess(problem, lambda t: qa + (qb - qa) * np.clip(t, 0, 1)[:, None])
        robot.apply_limits(problem)
        problem.minimize_effort()
        if bound is not None:
            F = problem.joint_force("j1")
            problem.subject_to(ca.dot(F, F), -np.inf, bound**2, "j1 force")
        sol = problem.solve(oc.Radau(10, degree=3))
        loads = sol.loads()
        return sol, np.sqrt(sum(loads[f"j1.F_{a}"] ** 2 for a in "xyz")).max()

    free, peak = solve(None)
    bounded, peak_b = solve(0.95 * peak)
    assert peak_b == pytest.approx(0.95 * peak, rel=1e-8) and bounded.objective > free.objective
    assert max(bounded.residuals()) <= 1e-12


def test_auto_falls_back_to_maximal_coordinates_where_the_joint_form_cannot_be_built(monkeypatch):
    # "auto" must never make a problem fail that the maximal form solves: where the joint form
    # cannot be written (e.g. Euler angles singular at the joint coordinates' zero), it falls back.
    import ocp_constraints.ocp.joint_transcription as jt

    def refuse(problem, scheme):
        raise ModelError("body 'rod': its Euler angles are singular at the joint coordinates' zero")

    monkeypatch.setattr(jt, "transcribe_joint", refuse)
    _, auto = oc.build_task("pendulum", "swing_up")
    assert auto.nlp_coordinates == "joint"
    sol = auto.solve(oc.Radau(20, degree=3))
    assert auto.nlp_coordinates == "maximal" and not isinstance(sol.transcription, JointTranscription)
    assert sol.objective == pytest.approx(8.913005, rel=1e-3)      # the Pontryagin optimum (README)
    _, explicit = oc.build_task("pendulum", "swing_up")
    explicit.coordinates = "joint"                                  # asked for: the error, not a fallback
    with pytest.raises(ModelError, match="singular"):
        explicit.solve(oc.Radau(20, degree=3))
