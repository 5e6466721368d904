"""URDF import (``oc.load_urdf``) against Pinocchio, the robotics reference.

Along a random smooth joint motion of three robots of ``example-robot-data`` (the UR5, a
6-axis arm; the Panda, a 7-axis arm whose hand branches into two prismatic fingers; Solo-12,
a quadruped with four branches) our inverse dynamics on the imported model (maximal
coordinates, Lagrange's prescription) gives every joint's constraint force and moment and
every actuator's input. Pinocchio's RNEA gives the joint torques and ``data.f``, the spatial
force the parent transmits to each joint's subtree, in the joint frame about its origin. The
transmitted wrench is the constraint load plus the actuator's torque (force) along the axis;
both are compared, component by component, to 1e-9 of the largest. Fixed joints (our welds)
are compared with the same Pinocchio computation on a copy of the URDF in which each is a
revolute joint held at q = qd = qdd = 0 (Pinocchio merges fixed joints), and a root welded to
the ground with a free-flyer root joint held still.

Pinocchio (``pin``) and ``example-robot-data`` are optional peers (the ``bench`` extra); the
tests that need them skip with the reason when they are missing.
"""
from __future__ import annotations

import re
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np
import pytest

import ocp_constraints as oc

pytest.importorskip("yourdfpy", reason="the URDF parser is the optional extra 'urdf' (pip install yourdfpy)")


def _robots_dir() -> Path | None:
    try:
        d = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    except PackageNotFoundError:
        return None
    return d if d.is_dir() else None


ROBOTS = _robots_dir()
needs_robots = pytest.mark.skipif(ROBOTS is None, reason="example-robot-data is not installed (pip install example-robot-data)")
URDFS = {"ur5": "ur_description/urdf/ur5_robot.urdf", "panda": "panda_description/urdf/panda.urdf",
         "solo12": "solo_description/robots/solo12.urdf"}


def _motion(n: int, samples: int, seed: int, prismatic: list[bool]):
    """A random smooth joint motion (three sines per joint) with its exact rates and accelerations."""
    rng = np.random.default_rng(seed)
    A, w, ph = rng.uniform(0.2, 0.8, (3, n)), rng.uniform(0.5, 3.0, (3, n)), rng.uniform(0, 2 * np.pi, (3, n))
    A[:, prismatic] *= 0.03                                  # fingers travel centimetres
    t = np.linspace(0.0, 2.0, samples)[:, None]
    q = sum(A[k] * np.sin(w[k] * t + ph[k]) for k in range(3))
    qd = sum(A[k] * w[k] * np.cos(w[k] * t + ph[k]) for k in range(3))
    qdd = sum(-A[k] * w[k] ** 2 * np.sin(w[k] * t + ph[k]) for k in range(3))
    return t.ravel(), q, qd, qdd


def _pinocchio_with_welds_as_joints(path: Path, robot, tmp_path: Path):
    """Pinocchio's model of a copy of ``path`` whose fixed joints that we weld are revolute joints."""
    pin = pytest.importorskip("pinocchio", reason="Pinocchio is an optional peer (pip install pin)")
    text = path.read_text()
    for rj in robot.joints.values():
        if rj.type == "fixed" and rj.urdf_name != "ground_weld":
            pattern = re.compile(r'(<joint\s+name="%s"\s+type=")fixed("\s*>)' % re.escape(rj.urdf_name))
            text, n = pattern.subn(r'\1revolute\2<axis xyz="0 0 1"/><limit effort="1" lower="-1" upper="1" '
                                   r'velocity="1"/>', text)
            assert n == 1, rj.urdf_name
    copy = tmp_path / path.name
    copy.write_text(text)
    if "ground_weld" in robot.joints:
        return pin, pin.buildModelFromUrdf(str(copy), pin.JointModelFreeFlyer())
    return pin, pin.buildModelFromUrdf(str(copy))


@needs_robots
@pytest.mark.parametrize("name", sorted(URDFS))
def test_joint_reaction_wrenches_match_pinocchio(name, tmp_path):
    path = ROBOTS / URDFS[name]
    robot = oc.load_urdf(path)
    pin, pm = _pinocchio_with_welds_as_joints(path, robot, tmp_path)
    pd = pm.createData()
    n = len(robot.joint_names)
    t, q, qd, qdd = _motion(n, 12, seed=len(name), prismatic=[robot.joints[j].type == "prismatic" for j in robot.joint_names])
    res = oc.InverseDynamics(oc.SystemEquations(robot.model)).solve(t, *robot.body_states(q, qd, qdd))
    assert res.status == "solved"
    loads = res.loads()
    ids = {jn: pm.getJointId("root_joint" if jn == "ground_weld" else robot.urdf_names[jn]) for jn in robot.joints}
    assert all(i < pm.njoints for i in ids.values())
    assert pm.njoints - 1 == len(robot.joints)          # every joint of ours is one of Pinocchio's
    worst, scale = 0.0, 0.0
    for i in range(len(t)):
        qp, vp, ap = pin.neutral(pm), np.zeros(pm.nv), np.zeros(pm.nv)
        for k, jn in enumerate(robot.joint_names):
            jid = ids[jn]
            qp[pm.idx_qs[jid]], vp[pm.idx_vs[jid]], ap[pm.idx_vs[jid]] = q[i, k], qd[i, k], qdd[i, k]
        pin.forwardKinematics(pm, pd, qp, vp, ap)
        tau = pin.rnea(pm, pd, qp, vp, ap)
        for jn, rj in robot.joints.items():
            jid = ids[jn]
            prefix = jn if rj.parent is None else f"{jn}@{rj.child}"
            F, M, P = (np.array([loads[f"{prefix}.{c}_{a}"][i] for a in "xyz"]) for c in ("F", "M", "point"))
            R = pd.oMi[jid].rotation
            linear, angular = R.T @ F, R.T @ M            # the constraint load in the joint frame
            if rj.input is not None:
                drive = res.input(rj.input)[i]
                assert abs(drive - tau[pm.idx_vs[jid]]) <= 1e-9 * max(1.0, abs(tau).max())
                if rj.type == "prismatic":
                    linear = linear + drive * rj.axis
                else:
                    angular = angular + drive * rj.axis
            f = pd.f[jid]
            worst = max(worst, np.abs(linear - f.linear).max(), np.abs(angular - f.angular).max())
            scale = max(scale, np.abs(f.vector).max())
            assert np.allclose(P, pd.oMi[jid].translation, rtol=0, atol=1e-12)   # the load acts at the joint origin
    assert worst <= 1e-9 * scale, f"{name}: max wrench error {worst:.3g} (largest wrench component {scale:.3g})"


@needs_robots
def test_ur5_import_structure_limits_and_frames():
    robot = oc.load_urdf(ROBOTS / URDFS["ur5"])
    m = robot.model
    # 'world' (no inertial) is the ground; base_link is welded to it by the URDF's world_joint;
    # ee_link, base and tool0 have no mass: frames of the bodies they are fixed to.
    assert list(m.bodies) == ["base_link", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
                              "wrist_2_link", "wrist_3_link"]
    assert {j: rj.type for j, rj in robot.joints.items()} == {
        "world_joint": "fixed", "shoulder_pan_joint": "revolute", "shoulder_lift_joint": "revolute",
        "elbow_joint": "revolute", "wrist_1_joint": "revolute", "wrist_2_joint": "revolute", "wrist_3_joint": "revolute"}
    assert robot.frames["tool0"][0] == "wrist_3_link" and robot.frames["world"][0] is None
    assert np.allclose(robot.frames["tool0"][1][:3, 3], [0, 0.0823, 0])
    assert robot.urdf_names["base_link_base_fixed_joint"] == "base_link-base_fixed_joint"
    assert len(m.constraints) == 6 + 6 * 5                  # a weld (6) and six revolute joints (5 each)
    assert robot.limits["elbow_joint"].effort == 150.0 and robot.limits["wrist_3_joint"].velocity == 3.2
    assert robot.input_bounds["wrist_1_joint.tau"] == (-28.0, 28.0)
    # upper_arm_link: <inertial> origin (0, 0, 0.28), mass 8.393
    assert m.bodies["upper_arm_link"].mass == 8.393 and np.allclose(robot.com["upper_arm_link"], [0, 0, 0.28])
    assert "shoulder_lift_joint.w1.lambda" in m.describe()


@needs_robots
def test_joint_coordinates_are_read_back_from_the_bodies():
    robot = oc.load_urdf(ROBOTS / URDFS["panda"])
    n = len(robot.joint_names)
    _, q, qd, _ = _motion(n, 5, seed=3, prismatic=[robot.joints[j].type == "prismatic" for j in robot.joint_names])
    import casadi as ca

    eqs = oc.SystemEquations(robot.model)
    Q, U, _ = robot.body_states(q, qd)
    f = ca.Function("joint", [eqs.q, eqs.u], [ca.vertcat(*[robot.joint_position(j) for j in robot.joint_names]),
                                              ca.vertcat(*[robot.joint_rate(j) for j in robot.joint_names])])
    for i in range(len(q)):
        pos, rate = (np.asarray(v).ravel() for v in f(Q[i], U[i]))
        prismatic = np.array([robot.joints[j].type == "prismatic" for j in robot.joint_names])
        assert np.allclose(pos, np.where(prismatic, q[i], np.angle(np.exp(1j * q[i]))), rtol=0, atol=1e-12)
        assert np.allclose(rate, qd[i], atol=1e-12)


@needs_robots
def test_limit_constraints_hold_exactly_inside_the_urdf_range():
    robot = oc.load_urdf(ROBOTS / URDFS["panda"])
    import casadi as ca

    eqs = oc.SystemEquations(robot.model)
    rows = [r for r in robot.limit_constraints() if r[0] == "panda_joint6 position"]   # range -0.0175 ... 3.7525 rad
    assert len(rows) == 1
    _, expr, lo, hi = rows[0]
    g = ca.Function("g", [eqs.q], [expr])
    k = robot.joint_names.index("panda_joint6")
    for angle, inside in ((-0.02, False), (-0.015, True), (3.14, True), (3.75, True), (3.76, False), (5.0, False)):
        q = np.zeros(len(robot.joint_names))
        q[k] = angle
        value = float(g(robot.body_states(q)[0][0]))
        assert (lo <= value <= hi) == inside, angle


def _write(tmp_path, body: str) -> Path:
    p = tmp_path / "r.urdf"
    p.write_text(f'<?xml version="1.0"?>\n<robot name="r">{body}</robot>\n')
    return p


LINK = '<link name="{0}"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>'


@pytest.mark.parametrize("body, error, words", [
    (None, oc.DataFileError, "no such file"),
    ("<link name='a'", oc.DataFileError, "not a readable URDF"),
    (LINK.format("a") + LINK.format("b") + '<joint name="j" type="floating"><parent link="a"/><child link="b"/></joint>',
     oc.ModelError, "joint 'j' is of type 'floating'"),
    (LINK.format("a") + '<link name="m"/>' + LINK.format("b")
     + '<joint name="j1" type="revolute"><parent link="a"/><child link="m"/><axis xyz="0 0 1"/>'
       '<limit effort="1" lower="-1" upper="1" velocity="1"/></joint>'
     + '<joint name="j2" type="revolute"><parent link="m"/><child link="b"/><axis xyz="0 0 1"/>'
       '<limit effort="1" lower="-1" upper="1" velocity="1"/></joint>', oc.ModelError, "link 'm' has no mass"),
    (LINK.format("a") + LINK.format("b"), oc.DataFileError, "one root link"),
])
def test_bad_urdf_is_a_clear_error(tmp_path, body, error, words):
    path = tmp_path / "missing.urdf" if body is None else _write(tmp_path, body)
    with pytest.raises(error, match=re.escape(words)):
        oc.load_urdf(path)


def test_hand_written_pendulum_matches_its_closed_form(tmp_path):
    """A rod on a revolute joint about E2 (no peer needed): hinge force and motor torque in closed form."""
    m, l, J = 2.0, 0.5, 0.04
    path = _write(tmp_path, '<link name="world"/>' + '<link name="rod"><inertial><origin xyz="0 0 -{l}"/><mass value="{m}"/>'
                  '<inertia ixx="{J}" iyy="{J}" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>'.format(l=l, m=m, J=J)
                  + '<joint name="hinge" type="continuous"><parent link="world"/><child link="rod"/>'
                    '<origin xyz="0 0 1"/><axis xyz="0 1 0"/><limit effort="30" velocity="5"/></joint>')
    robot = oc.load_urdf(path)
    th, w, a = 0.7, 1.3, -0.4
    res = oc.InverseDynamics(oc.SystemEquations(robot.model)).solve([0.0], *robot.body_states([[th]], [[w]], [[a]]))
    g = 9.81
    # rod angle th about E2 from hanging: center of mass at (-l sin th, 0, 1 - l cos th)
    tau = (J + m * l**2) * a + m * g * l * np.sin(th)
    acc = np.array([-l * (a * np.cos(th) - w**2 * np.sin(th)), 0.0, l * (a * np.sin(th) + w**2 * np.cos(th))])
    F = m * acc - m * np.array([0, 0, -g])                 # hinge force on the rod
    L = res.loads()
    assert np.isclose(res.input("hinge.tau")[0], tau, rtol=1e-12)
    assert np.allclose([L[f"hinge.F_{c}"][0] for c in "xyz"], F, rtol=1e-12, atol=1e-12)
    assert robot.limits["hinge"].lower == -np.inf and robot.input_bounds == {"hinge.tau": (-30.0, 30.0)}


@needs_robots
def test_minimum_effort_swing_with_a_bound_on_a_joint_reaction_force():
    """The double pendulum of example-robot-data: rest to rest in 1 s, min int |tau|^2, then the same
    with |F| of joint1 on link1 bounded below the unbounded optimum's peak: the bound is active
    and costs effort (a larger optimum)."""
    import casadi as ca

    robot = oc.load_urdf(ROBOTS / "double_pendulum_description/urdf/double_pendulum.urdf", base="ground")
    qa, qb = np.array([0.0, 0.0]), np.array([1.0, -0.5])

    def solve(Fmax):
        p = oc.OptimalControlProblem(robot.model, t_final=1.0)
        robot.set_boundary(p, "initial", qa)
        robot.set_boundary(p, "final", qb)
        robot.set_guess(p, lambda t: qa + (qb - qa) * np.clip(t, 0, 1)[:, None])
        robot.apply_limits(p)
        p.minimize_effort()
        F = p.joint_force("joint1")
        if Fmax is not None:
            p.subject_to(ca.dot(F, F), -np.inf, Fmax**2, "joint1 force")
        sol = p.solve(oc.Radau(10, degree=3), {"ipopt.print_level": 0, "print_time": False})
        L = sol.loads()
        return sol, np.sqrt(sum(L[f"joint1.F_{a}"] ** 2 for a in "xyz")).max()

    free, peak = solve(None)
    bounded, peak_b = solve(0.95 * peak)
    assert free.success and bounded.success
    assert peak_b == pytest.approx(0.95 * peak, rel=1e-6)
    assert bounded.objective > free.objective
    assert max(bounded.residuals()) < 1e-9


@needs_robots
def test_robot_arm_example_prints_pinocchios_loads_and_an_active_reaction_bound():
    """examples/robot_arm_urdf.py (UR5, --intervals 4): its table of peak joint loads along the motion it
    defines equals Pinocchio's RNEA on the same motion (to the two printed decimals), and its bounded
    optimum has the bound active and a larger objective."""
    import os
    import subprocess
    import sys

    pin = pytest.importorskip("pinocchio", reason="Pinocchio is an optional peer (pip install pin)")
    example = Path(__file__).resolve().parents[1] / "examples" / "robot_arm_urdf.py"
    proc = subprocess.run([sys.executable, str(example), "--intervals", "4"], capture_output=True, text=True,
                          timeout=600, env={**os.environ, "MPLBACKEND": "Agg"})
    assert proc.returncode == 0, proc.stderr
    text = proc.stdout
    pm = pin.buildModelFromUrdf(str(ROBOTS / URDFS["ur5"]))
    pd = pm.createData()
    names = [pm.names[i] for i in range(1, pm.njoints)]
    t = np.linspace(0.0, 2.0, 41)[:, None]                  # the example's motion
    w = np.linspace(0.6, 1.6, 6)
    q, qd, qdd = 0.6 * np.sin(w * t), 0.6 * w * np.cos(w * t), -0.6 * w**2 * np.sin(w * t)
    peaks = {n: np.zeros(3) for n in names}
    for i in range(len(t)):
        tau = pin.rnea(pm, pd, q[i], qd[i], qdd[i])
        for k, n in enumerate(names):
            f = pd.f[k + 1]
            kind = pm.joints[k + 1].shortname()             # JointModelRY: a revolute joint about the joint frame's y
            axis = np.eye(3)["XYZ".index(kind[-1])] if kind in ("JointModelRX", "JointModelRY", "JointModelRZ") \
                else np.asarray(pm.joints[k + 1].extract().axis, float)
            moment = f.angular - tau[k] * axis                  # the constraint moment: the motor's taken off
            peaks[n] = np.maximum(peaks[n], [np.linalg.norm(f.linear), np.linalg.norm(moment), abs(tau[k])])
    for n in names:
        m = re.search(rf"{n}\s+max \|F_c\| =\s+([\d.]+) N\s+max \|M_c\| =\s+([\d.]+) N m\s+max \|tau\| =\s+([\d.]+)", text)
        assert m, f"{n} not in:\n{text}"
        assert np.allclose([float(g) for g in m.groups()], peaks[n], rtol=0, atol=0.0051), (n, m.groups(), peaks[n])
    bound = float(re.search(r"with \|F_c\| <= ([\d.]+) N", text).group(1))
    peak_b = float(re.search(r"peak \|F_c\| ([\d.]+) N \(\d+ IPOPT", text).group(1))
    free = float(re.search(r"minimum effort: objective ([\d.]+)", text).group(1))
    bounded = float(re.search(r"with \|F_c\| <= [\d.]+ N: objective ([\d.]+)", text).group(1))
    assert peak_b == pytest.approx(bound, abs=0.011) and bounded > free


@needs_robots
def test_c_export_of_an_imported_robot_round_trips(tmp_path):
    """The C export works on an imported model as on any other: every exported function (residuals,
    gradients, loads, inverse-dynamics multipliers) compiled, loaded back and compared with CasADi on
    200 random states (the export's own round trip) to 1e-12."""
    import shutil

    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler (cc/gcc) on this machine")
    from ocp_constraints.codegen.export import export_model_c

    robot = oc.load_urdf(ROBOTS / "double_pendulum_description/urdf/double_pendulum.urdf", base="ground")
    eqs = oc.SystemEquations(robot.model)
    report = export_model_c(eqs, tmp_path / "robot", "double pendulum", verify=True, n_states=200)
    assert report.round_trip.max_error <= 1e-12 and report.round_trip.n_states == 200
    assert (tmp_path / "robot" / "double_pendulum_constraints.h").is_file()
