"""A refinement whose first mesh is too coarse for the motion starts again from a finer mesh (ocp/mesh_progress.py,
``restarted``).

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
