"""User problems that solve(tolerance=...) mishandled: a first mesh too coarse for the motion (it starts again from a
multi-start: ocp/mesh_progress.py, ``restarted``), a body without constraints.

The seventh newcomer's URDF arm (results/bench/refinement_newcomer7.md): a planar two-link arm loaded from a URDF,
from hanging at rest to rest at (pi/4, pi/3) in 1 s, least effort, the shoulder's torque bounded by 4.5 N m. It has several optima, and which one a cold start reaches depends on the mesh and the machine: from the
default first mesh (Radau 5 x 10) IPOPT reached an optimum of that mesh alone on one (J = 28.87, link 2
spinning at 37 rad/s), and the pilot (Radau 7 x 20) does not solve warm from it. The reference is independent of the
library: plain CasADi, Lagrange's equations from the energies, Radau IIA degree 7, IPOPT tol 1e-12
(scripts/refinement_newcomer7/ref.py), started from the library's result.
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
REFERENCE_OBJECTIVE = 9.073986104630348     # scripts/refinement_newcomer7/ref.py urdf_arm: three phases, the bound's arc


def _independent_reference(sol):
    """The arm's optimum nearest ``sol``: scripts/refinement_newcomer7/ref.py (plain CasADi, Lagrange's equations from
    the energies, Radau IIA degree 7 on 160 uniform intervals, IPOPT tol 1e-12), started from ``sol``. Uniform: where the
    shoulder's bound is active on arcs (the optimum J = 62.34), its states are within 1e-5 at 160 intervals, 2e-3 at 80."""
    import importlib.util
    import pathlib

    path = pathlib.Path(__file__).parents[1] / "scripts" / "refinement_newcomer7" / "ref.py"
    spec = importlib.util.spec_from_file_location("newcomer7_ref", path)
    ref = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ref)
    system = ref.system("urdf_arm")
    return ref.transcribe(system, 160, 7, lambda frac: system["lib_guess"](sol, frac * system["T"]))


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


def test_the_urdf_arm_ends_in_the_pose_it_was_asked_and_its_starts_reach_the_references_optimum_the_best_no_worse(tmp_path):
    """set_boundary at the final end fixed one parameter per quaternion, which leaves the other's sign free: from
    some starts the arm ended with link 2 mirrored (-105 deg instead of 105 deg; J = 7.16), and a multi-start kept
    that. Eight starts (the problem's guess and perturbed ones): the best ends at the pose asked, read back as angles
    from its quaternions (2 atan2(qz, qw)); among the optima they reach is the independent three-phase reference's
    (scripts/refinement_newcomer7/ref.py: J = 9.073986104630348, its two resolutions within 1.3e-9), to Radau 3 x 20's
    discretization error, and the best is no worse. Which other optima the perturbed starts reach depends on the
    machine's floating point: on 2026-12-06 one start took 383 iterations to J = 7.2875, link 2 swung over the top
    (the same reference started from it: 7.3032), where earlier runs found 9.074 the lowest."""
    best = _arm(tmp_path).solve(oc.Radau(20, degree=3), starts=8)
    angles = [2 * np.arctan2(best.sample(f"{link}.qz")[-1], best.sample(f"{link}.qw")[-1]) for link in ("link1", "link2")]
    assert np.allclose(angles, [np.pi / 4, np.pi / 4 + np.pi / 3], atol=1e-9)
    optima = [o["objective"] for o in best.multistart["optima"]]
    assert any(o == pytest.approx(REFERENCE_OBJECTIVE, rel=1e-4) for o in optima), optima
    assert best.objective == min(optima) <= REFERENCE_OBJECTIVE * (1 + 1e-4)


@pytest.mark.slow
def test_the_urdf_arm_from_the_default_first_mesh_ends_met_at_an_optimum_the_independent_reference_confirms(tmp_path):
    """The arm has several optima (J = 9.074 with the shoulder's bound active on an arc, 12.42, 35.27, 62.34, ...), and
    which one a single cold start reaches depends on the mesh, and on the machine's floating point (casadi 3.8.2 on an
    AMD EPYC: the first mesh reaches 28.87, its pilot does not solve from it, and the refinement starts again from a
    multi-start, mesh_progress.restarted, whose best it refines to 9.073986). Whichever: the result is met, and the
    independent reference started from it lands on the same optimum, to the tolerance. Before (session 13): the
    first mesh's spurious optimum was returned, "met" False, its error not estimated."""
    sol = _arm(tmp_path).solve(tolerance=1e-4)
    record = sol.mesh_refinement
    assert record["met"] and max(record["estimate"]["states"], record["estimate"]["multipliers"]) <= 1e-4
    reference = _independent_reference(sol)
    assert sol.objective == pytest.approx(reference["objective"], rel=1e-5)
    t = reference["frac"] * reference["T"]
    for name in ("link1.x", "link1.y", "link2.x", "link2.y", "link1.omega_z", "link2.omega_z"):
        assert np.abs(np.asarray(sol.interpolate(name, t)).ravel() - reference["states"][name]).max() <= 1e-4, name
    if "restarted" in record:       # both attempts are counted in the refinement's time
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
