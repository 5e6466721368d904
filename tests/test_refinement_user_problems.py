"""User problems that solve(tolerance=...) mishandled: a first mesh too coarse for the motion (it starts again from a
finer mesh: ocp/mesh_progress.py, ``restarted``), a body without constraints.

The seventh newcomer's URDF arm (results/bench/refinement_newcomer7.md): a planar two-link arm loaded from a URDF,
from hanging at rest to rest at (pi/4, pi/3) in 1 s, least effort, the shoulder's torque bounded by 4.5 N m (active
on an arc). From the default first mesh (Radau 5 x 10) IPOPT reaches an optimum of that mesh alone (J = 28.87, link 2
spinning at 37 rad/s), and the pilot (Radau 7 x 20) does not solve warm from it. The reference is independent of the
library: three phases in plain CasADi with free junction times, Radau IIA degree 7 on 60 and 120 intervals, IPOPT tol
1e-12 (``cd scripts/refinement_newcomer7 && python ref.py urdf_arm``; J = 9.073986104630348, the two resolutions
within 1.3e-9).
"""
import numpy as np
import pytest

import ocp_constraints as oc

ARM_URDF = """<?xml version="1.0"?>
<robot name="planar_arm2">
  <link name="base_link"/>
  <link name="link1">
    <inertial><origin xyz="0.25 0 0" rpy="0 0 0"/><mass value="1.0"/>
      <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0208333333333" iyz="0" izz="0.0208333333333"/></inertial>
  </link>
  <link name="link2">
    <inertial><origin xyz="0.2 0 0" rpy="0 0 0"/><mass value="0.8"/>
      <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0106666666667" iyz="0" izz="0.0106666666667"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="link1"/><origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.5" upper="3.5" effort="100" velocity="50"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="link1"/><child link="link2"/><origin xyz="0.5 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.5" upper="3.5" effort="100" velocity="50"/>
  </joint>
</robot>
"""
REFERENCE_OBJECTIVE = 9.073986104630348


def _arm(tmp_path):
    path = tmp_path / "arm2.urdf"
    path.write_text(ARM_URDF)
    robot = oc.load_urdf(str(path), base="ground", gravity=(0.0, -9.81, 0.0))
    problem = oc.OptimalControlProblem(robot.model, t_final=1.0)
    start, end = np.array([-np.pi / 2, 0.0]), np.array([np.pi / 4, np.pi / 3])
    robot.set_boundary(problem, "initial", start)
    robot.set_boundary(problem, "final", end)

    def guess(s):
        s = np.clip(np.asarray(s, float), 0.0, 1.0)
        return start + (end - start) * (3 * s**2 - 2 * s**3)[:, None]

    robot.set_guess(problem, guess)
    problem.bound("shoulder.tau", -4.5, 4.5)
    problem.minimize_effort()
    return problem


def test_a_first_mesh_too_coarse_for_the_motion_is_dropped_and_the_refinement_starts_again_from_the_pilots_mesh(tmp_path):
    """Before: the first mesh's spurious optimum was returned, "met" False, its error not estimated."""
    sol = _arm(tmp_path).solve(tolerance=1e-4)
    record = sol.mesh_refinement
    earlier = record["restarted"]
    assert earlier["solution"]["points"] == 51 and earlier["solution"]["objective"] > 20.0     # the coarse mesh's own optimum
    assert "did not" in earlier["message"] and "started again from 20 intervals, 141 points" in record["message"]
    assert record["met"] and max(record["estimate"]["states"], record["estimate"]["multipliers"]) <= 1e-4
    assert sol.objective == pytest.approx(REFERENCE_OBJECTIVE, rel=1e-6)
    # both attempts are counted in the refinement's time
    assert record["total_cpu_s"] > sum(h["cpu_s"] + h.get("companion_cpu_s", 0.0) for h in record["history"])


def test_a_free_body_without_constraints_is_refined_to_its_tolerance_against_the_closed_form():
    """A tenth newcomer's free body (results/bench/refinement_newcomer10.md, flag 1): no joint, so no multiplier at
    all; solve(tolerance=...) raised a raw ValueError (an empty array reshaped, in the pilot's Legendre prediction).
    Here a body (quaternion) turned about the fixed E3 through THETA in T, rest to rest, by one torque about E3, least
    int tau^2: the double integrator's optimum, psi = THETA (3 s^2 - 2 s^3), tau = J33 psi'' (s = t / T)."""
    theta, t_final, j33 = 1.2, 2.0, 3.0
    model = oc.Model("free_body", gravity=(0.0, 0.0, 0.0))
    body = model.add_body("body", 1.0, np.diag([1.0, 2.0, j33]), rotation="quaternion")
    model.add_torque("motor", body, np.array([0.0, 0.0, 1.0]) * model.add_input("motor"))
    problem = oc.OptimalControlProblem(model, t_final=t_final)
    rest = {f"body.omega_{a}": 0.0 for a in "xyz"} | {f"body.vbar_{a}": 0.0 for a in "xyz"}
    problem.initial({"body.x": 0.0, "body.y": 0.0, "body.z": 0.0, "body.qw": 1.0, "body.qx": 0.0, "body.qy": 0.0,
                     "body.qz": 0.0} | rest)
    problem.final({"body.qw": np.cos(theta / 2), "body.qx": 0.0, "body.qy": 0.0, "body.qz": np.sin(theta / 2)} | rest)
    problem.minimize_effort()
    sol = problem.solve(tolerance=1e-6)
    record = sol.mesh_refinement
    assert record["met"], record["message"]
    t = np.linspace(0.0, t_final, 2001)
    s = t / t_final
    psi = theta * (3 * s**2 - 2 * s**3)
    exact = {"body.qw": np.cos(psi / 2), "body.qz": np.sin(psi / 2),
             "body.omega_z": theta * (6 * s - 6 * s**2) / t_final}
    true = max(float(np.abs(sol.interpolate(name, t) - value).max()) for name, value in exact.items())
    assert 0.1 * record["estimate"]["states"] <= true <= record["estimate"]["states"]
    torque = j33 * theta * (6 - 12 * s) / t_final**2
    assert np.abs(sol.interpolate("motor", t) - torque).max() <= record["estimate"]["inputs"] * np.abs(torque).max()
