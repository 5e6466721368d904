"""Constraints and Lagrange's prescription for every joint of ``ocp_constraints.mechanics.joints``.

For each joint type a small model is built (Euler and quaternion bodies). Each case also
writes, *independently* of the library (hand-written rotation tensors, eq. (11) dual
basis, ``v_C = vbar + omega x (x_C - xbar)``), the constraint functions it should
produce and the loads Table 1 of the paper prescribes. The tests check:

* the assembled constraint ``G u + e`` equals the independently written one;
* ``f``, ``h`` and the application point of every share equal Table 1;
* the power identity ``F_c . v_C + M_c . omega + lambda e_C = 0`` (eq. 27) on the
  constraint manifold (and ``= lambda pi`` off it) with the library's loads;
* equipollence (eqs. 28, 32-33): the same constraint written at another material point
  gives the same multiplier and an equipollent load;
* equal and opposite forces of a ball-and-socket between two bodies (sec. 6);
* the error paths: non-affine constraints, foreign symbols, redundant constraints.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ocp_constraints import joints
from ocp_constraints.mechanics.bodies import Body
from ocp_constraints.mechanics.constraints import derive_prescription
from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.errors import ModelError, NonAffineConstraintError, RedundantConstraintsError
from ocp_constraints.mechanics.model import Model
from ocp_constraints.mechanics.rotations import UnitQuaternion
from ocp_constraints.scenes.registry import build_scene
from ocp_constraints.dynamics.simulate import simulate
from ocp_constraints.mechanics.state import consistent_state

E1, E2, E3 = (ca.DM(v) for v in np.eye(3))
E = [E1, E2, E3]
ZERO = ca.DM.zeros(3, 1)
J_A = [[0.040, 0.003, 0.006], [0.003, 0.020, -0.005], [0.006, -0.005, 0.050]]
J_B = [[0.045, -0.002, 0.003], [-0.002, 0.008, 0.001], [0.003, 0.001, 0.042]]
DISK_M, DISK_R = 1.0, 0.15
DISK_J = np.diag([DISK_M * DISK_R**2 / 4, DISK_M * DISK_R**2 / 4, DISK_M * DISK_R**2 / 2])
SEEDS = st.integers(0, 2**31 - 1)


# -- independent kinematics of a library body --------------------------------------------
class Indep:
    """Positions, velocities and dual bases of a body, computed without the library."""

    def __init__(self, kin, body: Body):
        self.kin, self.body = kin, body
        if isinstance(body.rotation, UnitQuaternion):
            self.Q = kin.quaternion_rotation(body.q[3:7])
            self.seq = None
        else:
            self.seq = body.rotation.axes
            self.Q = kin.rotation_of_sequence(self.seq, body.q[3:6])

    @property
    def xbar(self):
        return self.body.q[0:3]

    def x(self, r):
        """Position of the material point at body-basis offset ``r`` from the center of mass."""
        return self.xbar + self.Q @ ca.DM(r)

    def v(self, x_point):
        """Velocity of the material point now at ``x_point`` (paper eq. 8)."""
        return self.body.vbar + ca.cross(self.body.omega, x_point - self.xbar)

    def dual(self, i: int):
        """``g^i``: eq. (11) for 3-1-3, else the rows of the inverse of ``[g_1 g_2 g_3]``."""
        angles = self.body.q[3:6]
        if self.seq == "313":
            return self.kin.dual_basis_313_eq11(angles)[i - 1]
        G = ca.horzcat(*self.kin.euler_basis_from_axial(self.seq, angles))
        return ca.inv(G)[i - 1, :].T

    def disk_contact(self, R):
        """Lowest edge point of a disk: ``x_P = xbar - R e2''``, ``e2'' = R3(psi) R1(theta) E2`` (Fig. 1)."""
        psi, theta = self.body.q[3], self.body.q[4]
        e2pp = self.kin.rot(3, psi) @ self.kin.rot(1, theta) @ E2
        return self.xbar - R * e2pp


@dataclass
class Case:
    """A small model, its constraints written independently, and Table 1's prescription."""

    model: Model
    pi: list  # independent constraint functions, model order
    shares: dict  # constraint name -> {body name: (point position, f, h)}
    random_q: object  # rng -> q


def _random_rotation_params(rng, body: Body):
    if isinstance(body.rotation, UnitQuaternion):
        q = rng.normal(size=4)
        return q / np.linalg.norm(q)
    a = rng.uniform(-math.pi, math.pi, 3)
    a[1] = rng.uniform(0.3, math.pi - 0.3) if body.rotation.is_proper else rng.uniform(-1.2, 1.2)
    return a


def _random_q_for(model: Model):
    def draw(rng):
        return np.concatenate([np.concatenate([rng.normal(size=3), _random_rotation_params(rng, b)])
                               for b in model.bodies.values()])
    return draw


def _disk(model: Model, rotation="313"):
    disk = model.add_body("disk", DISK_M, DISK_J, rotation=rotation)
    phi = disk.rotation_parameters[2]
    P = disk.point("P", -DISK_R * ca.vertcat(ca.sin(phi), ca.cos(phi), 0))
    return disk, P


# -- the cases: one per joint type -------------------------------------------------------
def case_ball_and_socket_to_ground(kin):
    m = Model("ball_ground")
    b = m.add_body("b", 1.3, J_A, rotation="quaternion")
    rA = [0.1, -0.3, 0.2]
    A = b.point("A", rA)
    joints.ball_and_socket(m, "ball", A, anchor=(0.2, 0.1, -0.3))
    ib = Indep(kin, b)
    xA = ib.x(rA)
    pi = [ca.dot(E[k], ib.v(xA)) for k in range(3)]
    shares = {f"ball.v{k + 1}": {"b": (xA, E[k], ZERO)} for k in range(3)}
    return Case(m, pi, shares, _random_q_for(m))


def case_ball_and_socket_two_bodies(kin):
    m = Model("ball_two")
    b1 = m.add_body("b1", 1.0, J_A, rotation="313")
    b2 = m.add_body("b2", 0.8, J_B, rotation="quaternion")
    c1, c2 = [0.02, -0.5, 0.03], [-0.03, 0.4, 0.02]
    C1, C2 = b1.point("C", c1), b2.point("C", c2)
    joints.ball_and_socket(m, "link", C1, C2)
    i1, i2 = Indep(kin, b1), Indep(kin, b2)
    x1, x2 = i1.x(c1), i2.x(c2)
    pi = [ca.dot(E[k], i1.v(x1)) - ca.dot(E[k], i2.v(x2)) for k in range(3)]
    shares = {f"link.v{k + 1}": {"b1": (x1, E[k], ZERO), "b2": (x2, -E[k], ZERO)} for k in range(3)}
    return Case(m, pi, shares, _random_q_for(m))


def case_revolute(kin):
    m = Model("revolute")
    b = m.add_body("rod", 1.1, J_B, rotation="quaternion")
    rA = [0.0, 0.45, -0.05]
    A = b.point("A", rA)
    joints.revolute(m, "hinge", A, axis=(0, 0, 1), anchor=(0.1, 0.2, 0.3))
    ib = Indep(kin, b)
    xA = ib.x(rA)
    pi = [ca.dot(E[k], ib.v(xA)) for k in range(3)] + [ca.dot(E1, b.omega), ca.dot(E2, b.omega)]
    shares = {f"hinge.v{k + 1}": {"rod": (xA, E[k], ZERO)} for k in range(3)}
    shares["hinge.w1"] = {"rod": (xA, ZERO, E1)}  # Table 1: M_c = lambda_4 E1 + lambda_5 E2
    shares["hinge.w2"] = {"rod": (xA, ZERO, E2)}
    return Case(m, pi, shares, _random_q_for(m))


def case_sliding_contact(kin):
    m = Model("sliding")
    disk, P = _disk(m)
    joints.sliding_contact(m, "contact", P)
    xP = Indep(kin, disk).disk_contact(DISK_R)
    pi = [ca.dot(E3, Indep(kin, disk).v(xP))]
    return Case(m, pi, {"contact.n": {"disk": (xP, E3, ZERO)}}, _random_q_for(m))


def case_sliding_contact_moving_surface(kin):
    m = Model("sliding_moving")
    disk, P = _disk(m, rotation="quaternion")
    n = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    rate = 0.4 * ca.sin(2 * m.t) + 0.1
    # A fixed material point Q of a quaternion body slides on a moving inclined plane.
    rP = [0.05, -0.1, 0.12]
    Qp = disk.point("Q", rP)
    joints.sliding_contact(m, "contact", Qp, normal=n, rate=rate)
    ib = Indep(kin, disk)
    xQ = ib.x(rP)
    pi = [ca.dot(ca.DM(n), ib.v(xQ)) - (0.4 * ca.sin(2 * m.t) + 0.1)]
    return Case(m, pi, {"contact.n": {"disk": (xQ, ca.DM(n), ZERO)}}, _random_q_for(m))


def case_rolling_contact(kin):
    m = Model("rolling")
    disk, P = _disk(m)
    vs = ca.DM([0.3, -0.2, 0.0])
    joints.rolling_contact(m, "roll", P, surface_velocity=(0.3, -0.2, 0.0))
    ib = Indep(kin, disk)
    xP = ib.disk_contact(DISK_R)
    pi = [ca.dot(E[k], ib.v(xP)) - ca.dot(E[k], vs) for k in range(3)]
    shares = {f"roll.v{k + 1}": {"disk": (xP, E[k], ZERO)} for k in range(3)}
    return Case(m, pi, shares, _random_q_for(m))


def case_sliding_cylinder(kin):
    m = Model("cylinder")
    mass, r, h = 1.5, 0.2, 0.6
    It, Ia = mass * (3 * r**2 + h**2) / 12, mass * r**2 / 2
    cyl = m.add_body("cyl", mass, np.diag([It, It, Ia]), rotation="313")
    joints.sliding_cylinder(m, "plane", cyl)
    ib = Indep(kin, cyl)
    n_tilt = ca.cross(ib.Q[:, 2], E3)
    pi = [ca.dot(E3, cyl.vbar), ca.dot(n_tilt, cyl.omega)]
    shares = {"plane.normal": {"cyl": (ib.xbar, E3, ZERO)}, "plane.tilt": {"cyl": (ib.xbar, ZERO, n_tilt)}}
    return Case(m, pi, shares, _random_q_for(m))


def case_driven_axis_321(kin):
    m = Model("driven")
    b = m.add_body("arm", 1.2, J_A, rotation="321")
    Omega = 1.5 + 0.5 * ca.sin(m.t)
    joints.driven_axis(m, "motor", b, Omega, index=2)
    g2 = Indep(kin, b).dual(2)
    pi = [ca.dot(g2, b.omega) - (1.5 + 0.5 * ca.sin(m.t))]
    return Case(m, pi, {"motor.drive": {"arm": (b.q[0:3], ZERO, g2)}}, _random_q_for(m))


def case_fixed_angle_313(kin):
    m = Model("locked")
    b = m.add_body("arm", 1.2, J_A, rotation="313")
    joints.fixed_angle(m, "lock", b, index=3, value=0.2)
    g3 = Indep(kin, b).dual(3)
    return Case(m, [ca.dot(g3, b.omega)], {"lock.lock": {"arm": (b.q[0:3], ZERO, g3)}}, _random_q_for(m))


def case_whirling_scene(kin):
    """Table 1, whirling row: ``F_c = sum lambda_k E_k`` at X_A, ``M_c = lambda_4 g^1 + lambda_5 g^3``."""
    scene = build_scene("whirling", {"omega_amplitude": 0.5})
    m, p = scene.model, scene.model.parameters
    b = m.bodies["body"]
    ib = Indep(kin, b)
    xA = ib.x(-np.array([p["com_x"], p["com_y"], p["com_z"]]))
    g1, g3 = ib.dual(1), ib.dual(3)
    pi = [ca.dot(E[k], ib.v(xA)) for k in range(3)]
    pi += [ca.dot(g1, b.omega) - (p["omega"] + p["omega_amplitude"] * ca.sin(m.t)), ca.dot(g3, b.omega)]
    shares = {f"shaft.v{k + 1}": {"body": (xA, E[k], ZERO)} for k in range(3)}
    shares["shaft.drive"] = {"body": (xA, ZERO, g1)}
    shares["shaft.lock"] = {"body": (xA, ZERO, g3)}
    return Case(m, pi, shares, _random_q_for(m))


CASES = {
    "ball_and_socket_to_ground": case_ball_and_socket_to_ground,
    "ball_and_socket_two_bodies": case_ball_and_socket_two_bodies,
    "revolute": case_revolute,
    "sliding_contact": case_sliding_contact,
    "sliding_contact_moving_surface": case_sliding_contact_moving_surface,
    "rolling_contact": case_rolling_contact,
    "sliding_cylinder": case_sliding_cylinder,
    "driven_axis_321": case_driven_axis_321,
    "fixed_angle_313": case_fixed_angle_313,
    "whirling_scene": case_whirling_scene,
}


class Compiled:
    """Numeric functions of one case: library and independent."""

    def __init__(self, case: Case):
        self.case = case
        eqs = self.eqs = SystemEquations(case.model)
        pi = ca.vertcat(*case.pi)
        G = ca.jacobian(pi, eqs.u)
        e = ca.substitute(pi, eqs.u, ca.SX.zeros(eqs.nu))
        self.indep = ca.Function("indep", [eqs.q, eqs.u, eqs.t], [pi, G, e])
        self.offsets = {}
        start = 0
        for b in eqs.bodies:
            self.offsets[b.name] = (start, start + b.q.numel())
            start += b.q.numel()

    def consistent_speeds(self, q, t, rng):
        """Random speeds projected onto the independently written constraints."""
        u = rng.normal(size=self.eqs.nu) * 2
        _, G, e = (np.asarray(x) for x in self.indep(q, u, t))
        return u - np.linalg.pinv(G) @ (G @ u + e.ravel())

    def body_state(self, body_name, q, u):
        """``xbar, vbar, omega`` of a body from the model vectors."""
        names = list(self.case.model.bodies)
        i = names.index(body_name)
        qs, _ = self.offsets[body_name]
        return q[qs:qs + 3], u[6 * i:6 * i + 3], u[6 * i + 3:6 * i + 6]


@pytest.fixture(scope="module")
def compiled_cases(indep_kinematics):
    return {name: Compiled(build(indep_kinematics)) for name, build in CASES.items()}


@pytest.mark.parametrize("name", list(CASES))
def test_assembled_constraints_equal_the_independently_written_ones(compiled_cases, name):
    """``G u + e`` (library) equals the constraint written by hand at random ``q, u, t``."""
    c = compiled_cases[name]
    rng = np.random.default_rng(list(CASES).index(name))
    for _ in range(20):
        q, u, t = c.case.random_q(rng), rng.normal(size=c.eqs.nu) * 3, rng.uniform(0, 10)
        lib = np.asarray(c.eqs.constraint_functions(q, u, t, [])[3]).ravel()
        ind = np.asarray(c.indep(q, u, t)[0]).ravel()
        assert np.abs(lib - ind).max() <= 1e-13 * max(1, np.abs(u).max())


@pytest.mark.parametrize("name", list(CASES))
def test_prescription_of_every_share_matches_table1(compiled_cases, name):
    """Each constraint's ``(point, f, h)`` per body equals the paper's Table 1 / sec. 6 prescription."""
    c = compiled_cases[name]
    eqs = c.eqs
    rng = np.random.default_rng(100 + list(CASES).index(name))
    assert [k.name for k in eqs.constraints] == list(c.case.shares)
    for con in eqs.constraints:
        expected = c.case.shares[con.name]
        assert sorted(s.body.name for s in con.shares) == sorted(expected)
        for s in con.shares:
            x_exp, f_exp, h_exp = expected[s.body.name]
            fun = ca.Function("cmp", [eqs.q, eqs.t], [s.point.position - x_exp, s.f - f_exp, s.h - h_exp])
            for _ in range(10):
                d = fun(c.case.random_q(rng), rng.uniform(0, 10))
                assert max(float(np.abs(np.asarray(x)).max()) for x in d) <= 1e-13, (con.name, s.body.name)


def _power_terms(c: Compiled, q, u, t, lam):
    """Per joint: ``sum over its channels of F . v_C + M . omega`` and the library's power column."""
    eqs = c.eqs
    loads = np.asarray(eqs.loads_function(q, u, t, lam)).ravel().reshape(-1, 10)
    per_joint: dict[str, list] = {}
    for ch, row in zip(eqs.load_channels, loads):
        F, M, x, power = row[0:3], row[3:6], row[6:9], row[9]
        xbar, vbar, omega = c.body_state(ch.body, q, u)
        v_C = vbar + np.cross(omega, x - xbar)  # paper eq. 8, with the library's reported point
        terms = [float(F @ v_C), float(M @ omega)]
        per_joint.setdefault(ch.joint, []).append((terms, power))
    return per_joint


@settings(max_examples=15, deadline=None)
@given(seed=SEEDS)
@pytest.mark.parametrize("name", list(CASES))
def test_power_identity_holds_for_every_joint(compiled_cases, name, seed):
    """``F_c . v_C + M_c . omega + sum_k lambda_k e_k = 0`` on the manifold (eq. 27); ``= sum lambda pi`` off it."""
    c = compiled_cases[name]
    eqs = c.eqs
    rng = np.random.default_rng(seed)
    q, t = c.case.random_q(rng), rng.uniform(0, 10)
    lam = rng.normal(size=eqs.nc) * 5
    index = {k.name: i for i, k in enumerate(eqs.constraints)}
    for u, on_manifold in ((c.consistent_speeds(q, t, rng), True), (rng.normal(size=eqs.nu) * 2, False)):
        pi, _, e = (np.asarray(x).ravel() for x in c.indep(q, u, t))
        if on_manifold:
            assert np.abs(pi).max() <= 1e-12
        for joint, rows in _power_terms(c, q, u, t, lam).items():
            ks = [index[k.name] for k in eqs.model.joints[joint].constraints]
            lam_e = float(lam[ks] @ e[ks])
            lam_pi = float(lam[ks] @ pi[ks])
            mech = sum(sum(terms) for terms, _ in rows)
            scale = max([1.0, abs(lam_e), abs(lam_pi)] + [abs(x) for terms, _ in rows for x in terms])
            assert abs(mech + lam_e - lam_pi) <= 1e-13 * scale
            if on_manifold:
                assert abs(mech + lam_e) <= 1e-10 * scale  # the paper's identity
                assert abs(sum(p for _, p in rows) + lam_e) <= 1e-10 * scale  # the power column
            for terms, power in rows:
                assert abs(power - sum(terms)) <= 1e-13 * scale


def test_revolute_about_a_tilted_axis_has_moments_normal_to_it():
    """Revolute about ``n = (1, 2, 2)/3``: ``h_4, h_5`` orthonormal, normal to ``n``; forces ``E_k``."""
    m = Model("tilted")
    b = m.add_body("rod", 1.0, J_B, rotation="321")
    A = b.point("A", [0.0, 0.4, 0.0])
    n = np.array([1.0, 2.0, 2.0]) / 3
    joints.revolute(m, "hinge", A, axis=(1, 2, 2))
    shares = [k.shares[0] for k in m.constraints]
    fun = ca.Function("s", [b.q], [ca.horzcat(*[s.f for s in shares]), ca.horzcat(*[s.h for s in shares])])
    F, H = (np.asarray(x) for x in fun([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]))
    assert np.abs(F - np.column_stack([np.eye(3), np.zeros((3, 2))])).max() == 0
    h4, h5 = H[:, 3], H[:, 4]
    assert np.abs(H[:, :3]).max() == 0
    assert abs(h4 @ n) <= 1e-15 and abs(h5 @ n) <= 1e-15 and abs(h4 @ h5) <= 1e-15
    assert abs(np.linalg.norm(h4) - 1) <= 1e-15 and abs(np.linalg.norm(h5) - 1) <= 1e-15
    assert np.abs(np.cross(h4, h5) - n).max() <= 1e-15  # (a1, a2, n) right-handed


def test_derive_prescription_of_a_sliding_contact_is_normal_force_without_moment():
    """``derive_prescription`` of ``E3 . v_P`` gives ``e = 0``, ``f = E3``, ``h = 0`` at X_P (Table 1)."""
    m = Model("derive")
    disk, P = _disk(m)
    points = {}
    e, shares = derive_prescription("c", ca.dot(E3, P.v), [disk], m.t, ca.SX(0, 1), points)
    assert len(shares) == 1 and shares[0].point is P and points == {"disk": P}
    assert float(ca.evalf(e)) == 0.0
    assert np.asarray(ca.evalf(shares[0].f)).ravel().tolist() == [0.0, 0.0, 1.0]
    assert np.abs(np.asarray(ca.evalf(shares[0].h))).max(initial=0.0) == 0.0
    assert shares[0].has_force and not shares[0].has_moment


# -- equipollence (paper secs. 4.3, eqs. 28, 32-33) --------------------------------------
def _disk_at_center_of_mass_model(kin, point_for_joint: bool):
    """The sliding disk with the contact written at the center of mass (eq. 28)."""
    scene = build_scene("sliding_disk")
    p = scene.model.parameters
    m = Model("disk_com", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    disk, P = _disk(m)
    psi, theta = disk.q[3], disk.q[4]
    e2pp = kin.rot(3, psi) @ kin.rot(1, theta) @ E2
    expr = ca.dot(E3, disk.vbar) + ca.dot(ca.cross(-p["radius"] * e2pp, E3), disk.omega)
    m.add_constraint("contact.n", expr, joint="contact", position=disk.q[2] - p["radius"] * ca.sin(theta),
                     point=P if point_for_joint else None)
    return scene, m, e2pp


def _random_disk_state(rng, R):
    theta = rng.uniform(0.3, math.pi - 0.3)
    q = np.array([*rng.normal(size=2), R * math.sin(theta), rng.uniform(-3, 3), theta, rng.uniform(-3, 3)])
    return q


def test_sliding_disk_constraint_written_at_center_of_mass_is_equipollent(indep_kinematics):
    """Eq. (28) vs ``E3 . v_P = 0``: same lambda, ``F_c = lambda E3``, ``M_c = lambda (-R e2'' x E3)`` at the center of mass."""
    scene, m2, e2pp = _disk_at_center_of_mass_model(indep_kinematics, point_for_joint=False)
    eqs1, eqs2 = SystemEquations(scene.model), SystemEquations(m2)
    R = scene.model.parameters["radius"]
    e2f = ca.Function("e2pp", [eqs2.q], [e2pp])
    moved = eqs1.load_about_function("contact", scene.model.bodies["disk"].com)  # eq. (33)
    rng = np.random.default_rng(21)
    for _ in range(20):
        q, t = _random_disk_state(rng, R), rng.uniform(0, 5)
        u = rng.normal(size=6) * 2
        # Put u on the manifold with the independent constraint z' = R cos(theta) theta'.
        G = np.asarray(eqs2.constraint_functions(q, u, t, [])[0])
        u = u - np.linalg.pinv(G) @ (G @ u)
        ud1, lam1 = (np.asarray(x).ravel() for x in eqs1.forward_dynamics(q, u, t, [], []))
        ud2, lam2 = (np.asarray(x).ravel() for x in eqs2.forward_dynamics(q, u, t, [], []))
        assert abs(lam1[0] - lam2[0]) <= 1e-12 * max(1, abs(lam1[0]))
        assert np.abs(ud1 - ud2).max() <= 1e-12 * max(1, np.abs(ud1).max())
        l1 = np.asarray(eqs1.loads_function(q, u, t, lam1)).ravel()
        l2 = np.asarray(eqs2.loads_function(q, u, t, lam2)).ravel()
        F1, M1, x1 = l1[0:3], l1[3:6], l1[6:9]
        F2, M2, x2 = l2[0:3], l2[3:6], l2[6:9]
        xbar = q[0:3]
        e2 = np.asarray(e2f(q)).ravel()
        assert np.abs(x1 - (xbar - R * e2)).max() <= 1e-15  # F_c acts at X_P ...
        assert np.abs(x2 - xbar).max() <= 1e-15  # ... or at the center of mass
        assert np.abs(F1 - lam1[0] * np.eye(3)[2]).max() <= 1e-13 and np.abs(F2 - F1).max() <= 1e-13
        assert np.abs(M1).max() == 0
        assert np.abs(M2 - lam2[0] * np.cross(-R * e2, [0, 0, 1])).max() <= 1e-13 * abs(lam2[0])
        # Moments about the common point xbar (eq. 33).
        assert np.abs((M1 + np.cross(x1 - xbar, F1)) - (M2 + np.cross(x2 - xbar, F2))).max() <= 1e-13 * abs(lam1[0])
        F_moved, M_moved = (np.asarray(x).ravel() for x in moved(q, u, t, lam1))
        assert np.abs(F_moved - F2).max() <= 1e-13 * abs(lam1[0])
        assert np.abs(M_moved - lam1[0] * np.cross(-R * e2, [0, 0, 1])).max() <= 1e-13 * abs(lam1[0])


def test_sliding_disk_written_at_center_of_mass_simulates_the_same_normal_force(indep_kinematics):
    """Both formulations simulated for 1 s give the same trajectory and normal force."""
    scene, m2, _ = _disk_at_center_of_mass_model(indep_kinematics, point_for_joint=False)
    eqs1, eqs2 = SystemEquations(scene.model), SystemEquations(m2)
    q0, u0 = consistent_state(eqs1, scene.coordinates, scene.rates)
    q0b, u0b = consistent_state(eqs2, scene.coordinates, scene.rates)
    assert np.abs(q0 - q0b).max() == 0 and np.abs(u0 - u0b).max() <= 1e-14
    tr1, tr2 = simulate(eqs1, q0, u0, 1.0), simulate(eqs2, q0b, u0b, 1.0)
    mg = scene.model.parameters["mass"] * scene.model.parameters["gravity"]
    assert np.abs(tr1.lam - tr2.lam).max() <= 1e-8 * mg
    assert np.abs(tr1.q - tr2.q).max() <= 1e-9


def test_constraint_written_at_center_of_mass_is_moved_to_the_joint_point(indep_kinematics):
    """Eq. (32): eq. (28) attached to a joint acting at X_P becomes ``f = E3``, ``h = 0`` at X_P."""
    _, m2, _ = _disk_at_center_of_mass_model(indep_kinematics, point_for_joint=True)
    share = m2.constraints[0].shares[0]
    assert share.point is m2.bodies["disk"].points["P"]
    disk = m2.bodies["disk"]
    fun = ca.Function("fh", [disk.q], [share.f, share.h])
    rng = np.random.default_rng(4)
    for _ in range(20):
        f, h = (np.asarray(x).ravel() for x in fun(_random_disk_state(rng, DISK_R)))
        assert np.abs(f - [0, 0, 1]).max() <= 1e-15
        assert np.abs(h).max() <= 1e-15


def _whirling_with_pin_written_at_center_of_mass(kin):
    """The whirling scene with ``E_k . v_A = 0`` rewritten at the center of mass by eq. (32)."""
    scene = build_scene("whirling", {"omega_amplitude": 0.5})
    p = scene.model.parameters
    m = Model("whirling_com", gravity=(0.0, 0.0, -p["gravity"]), parameters=p)
    J = [[p["J11"], p["J12"], p["J13"]], [p["J12"], p["J22"], p["J23"]], [p["J13"], p["J23"], p["J33"]]]
    b = m.add_body("body", p["mass"], J, rotation="313")
    com = np.array([p["com_x"], p["com_y"], p["com_z"]])
    ib = Indep(kin, b)
    r_A = ib.x(-com) - ib.xbar  # x_A - xbar
    for k in range(3):
        # pi_A = f . v_A  ->  f . vbar + ((x_A - xbar) x f) . omega   (eq. 32 with X_A -> Xbar)
        m.add_constraint(f"shaft.v{k + 1}", ca.dot(E[k], b.vbar) + ca.dot(ca.cross(r_A, E[k]), b.omega), joint="shaft")
    Omega = p["omega"] + p["omega_amplitude"] * ca.sin(m.t)
    joints.driven_axis(m, "shaft", b, Omega, index=1)
    joints.fixed_angle(m, "shaft", b, index=3)
    return scene, m


def test_whirling_pin_written_at_center_of_mass_gives_same_multipliers_and_equipollent_load(indep_kinematics):
    """Eqs. (32)-(33) for a body with products of inertia and a time-dependent drive."""
    scene, m2 = _whirling_with_pin_written_at_center_of_mass(indep_kinematics)
    eqs1, eqs2 = SystemEquations(scene.model), SystemEquations(m2)
    assert eqs1.constraint_names == eqs2.constraint_names
    c1 = Compiled(case_whirling_scene(indep_kinematics))
    rng = np.random.default_rng(33)
    for _ in range(20):
        q, t = c1.case.random_q(rng), rng.uniform(0, 10)
        u = c1.consistent_speeds(q, t, rng)
        ud1, lam1 = (np.asarray(x).ravel() for x in eqs1.forward_dynamics(q, u, t, [], []))
        ud2, lam2 = (np.asarray(x).ravel() for x in eqs2.forward_dynamics(q, u, t, [], []))
        scale = max(1, np.abs(lam1).max())
        assert np.abs(lam1 - lam2).max() <= 1e-11 * scale
        assert np.abs(ud1 - ud2).max() <= 1e-11 * max(1, np.abs(ud1).max())
        l1 = np.asarray(eqs1.loads_function(q, u, t, lam1)).ravel()
        l2 = np.asarray(eqs2.loads_function(q, u, t, lam2)).ravel()
        F1, M1, x1, P1 = l1[0:3], l1[3:6], l1[6:9], l1[9]
        F2, M2, x2, P2 = l2[0:3], l2[3:6], l2[6:9], l2[9]
        assert np.abs(F1 - lam1[0:3]).max() <= 1e-13 * scale and np.abs(F2 - F1).max() <= 1e-12 * scale
        assert np.abs(x2 - q[0:3]).max() == 0  # the rewritten joint acts at the center of mass
        origin = np.zeros(3)
        assert np.abs((M1 + np.cross(x1 - origin, F1)) - (M2 + np.cross(x2 - origin, F2))).max() <= 1e-12 * scale
        # Same power: lambda_4 Omega (eq. 27) in both.
        Omega = scene.model.parameters["omega"] + scene.model.parameters["omega_amplitude"] * math.sin(t)
        assert abs(P1 - lam1[3] * Omega) <= 1e-10 * scale and abs(P2 - lam2[3] * Omega) <= 1e-10 * scale


# -- two bodies: equal and opposite (sec. 6) -----------------------------------------------
def test_ball_and_socket_between_two_bodies_gives_equal_and_opposite_forces():
    """``socket_C@body1.F = sum lambda_k E_k = -socket_C@body2.F`` at the common point, no moments."""
    scene = build_scene("ball_socket")
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 1.0)
    L = traj.loads()
    lam = np.column_stack([L[f"socket_C.v{k}.lambda"] for k in (1, 2, 3)])
    F1 = np.column_stack([L[f"socket_C@body1.F_{a}"] for a in "xyz"])
    F2 = np.column_stack([L[f"socket_C@body2.F_{a}"] for a in "xyz"])
    x1 = np.column_stack([L[f"socket_C@body1.point_{a}"] for a in "xyz"])
    x2 = np.column_stack([L[f"socket_C@body2.point_{a}"] for a in "xyz"])
    scale = np.abs(lam).max()
    assert scale > 1.0  # the joint carries load
    assert np.abs(F1 - lam).max() <= 1e-13 * scale
    assert np.abs(F1 + F2).max() <= 1e-13 * scale
    for body in ("body1", "body2"):
        assert max(np.abs(L[f"socket_C@{body}.M_{a}"]).max() for a in "xyz") == 0
    assert np.abs(x1 - x2).max() <= 1e-9  # X_C1 and X_C2 coincide (up to the integrator's drift)
    # Internal joint: the two bodies' powers cancel (e = 0).
    assert np.abs(L["socket_C@body1.power"] + L["socket_C@body2.power"]).max() <= 1e-8 * scale


# -- error paths ---------------------------------------------------------------------------
def test_non_affine_constraint_is_rejected_naming_constraint_and_velocity():
    """``P.v . P.v`` and ``omega_x vbar_y`` are not of the form (25): the error names both."""
    m = Model("bad")
    disk, P = _disk(m)
    with pytest.raises(NonAffineConstraintError) as info:
        m.add_constraint("speed_squared", ca.dot(P.v, P.v))
    msg = str(info.value)
    assert "'speed_squared'" in msg and "disk.P.v" in msg
    with pytest.raises(NonAffineConstraintError) as info:
        m.add_constraint("product", disk.omega[0] * disk.vbar[1])
    msg = str(info.value)
    assert "'product'" in msg and "disk.omega" in msg and "disk.vbar" in msg
    assert m.constraints == [] and m.joints == {}


def test_rejected_constraint_leaves_the_joint_unchanged():
    """A constraint rejected as non-affine must not change the joint it was meant for.

    Here it was to join joint ``link`` with ``point=B`` on a second body. After the
    rejection the joint should still act on body ``a`` only, so the corrected
    constraint can pick another point ``C`` on ``b``.
    """
    m = Model("leak")
    a = m.add_body("a", 1.0, J_A, rotation="quaternion")
    b = m.add_body("b", 1.0, J_B, rotation="quaternion")
    A = a.point("A", [0.1, 0.0, 0.0])
    B = b.point("B", [0.0, 0.2, 0.0])
    C = b.point("C", [0.0, -0.2, 0.0])
    joints.ball_and_socket(m, "link", A)
    before = dict(m.joints["link"].points)
    with pytest.raises(NonAffineConstraintError):
        m.add_constraint("bad", ca.dot(B.v, B.v), joint="link", point=B)
    assert [c.name for c in m.constraints] == ["link.v1", "link.v2", "link.v3"]
    assert m.joints["link"].points == before
    m.add_constraint("good", ca.dot(E1, C.v), joint="link", point=C)
    assert m.constraints[-1].shares[0].point is C


def test_constraint_with_a_foreign_symbol_is_rejected_naming_it():
    """A free symbol, or a body that was never added to the model, is named in the error."""
    m = Model("foreign")
    disk, P = _disk(m)
    k = ca.SX.sym("stiffness_k")
    with pytest.raises(ModelError) as info:
        m.add_constraint("springy", ca.dot(E3, P.v) - k * disk.q[2])
    assert "'springy'" in str(info.value) and "stiffness_k" in str(info.value)
    ghost = Body("ghost", 1.0, J_A)
    with pytest.raises(ModelError) as info:
        m.add_constraint("haunted", ca.dot(E3, P.v) - ca.dot(E3, ghost.vbar))
    assert "'haunted'" in str(info.value) and "ghost.vbar" in str(info.value)
    assert m.constraints == []


def _pinned_quaternion_body(name="pin"):
    m = Model(name)
    b = m.add_body("rod", 1.0, J_B, rotation="quaternion")
    rA = np.array([0.1, 0.4, -0.2])
    A = b.point("A", rA)
    half = 0.35  # rotation of 0.7 rad about E3: the body's e3 stays on the hinge axis E3
    quat = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])
    Q = np.array([[math.cos(0.7), -math.sin(0.7), 0], [math.sin(0.7), math.cos(0.7), 0], [0, 0, 1]])
    anchor = np.array([0.1, 0.2, 0.3])
    xbar = anchor - Q @ rA
    coords = {"rod.x": xbar[0], "rod.y": xbar[1], "rod.z": xbar[2],
              "rod.qw": quat[0], "rod.qx": quat[1], "rod.qy": quat[2], "rod.qz": quat[3]}
    return m, b, A, anchor, coords


def test_repeated_constraint_is_reported_as_redundant():
    """``E1 . v_A = 0`` twice: ``consistent_state`` names the repeat and what it repeats."""
    m, b, A, anchor, coords = _pinned_quaternion_body()
    joints.ball_and_socket(m, "ball", A, anchor=anchor)
    m.add_constraint("again", ca.dot(E1, A.v))
    with pytest.raises(RedundantConstraintsError) as info:
        consistent_state(SystemEquations(m), coords, {})
    msg = str(info.value)
    assert "'again' is a combination of 'ball.v1'" in msg
    assert msg.count("is a combination of") == 1  # the joint's own rows are not blamed


def test_vertical_velocity_of_another_point_on_a_revolute_body_is_redundant():
    """With ``v_A = 0`` and ``omega || E3``, ``E3 . v_B = E3 . v_A + ((x_B - x_A) x E3) . omega`` is implied."""
    m, b, A, anchor, coords = _pinned_quaternion_body("revolute_plus")
    B = b.point("B", [-0.3, 0.1, 0.25])
    joints.revolute(m, "hinge", A, axis=(0, 0, 1), anchor=anchor)
    m.add_constraint("extra", ca.dot(E3, B.v))
    eqs = SystemEquations(m)
    with pytest.raises(RedundantConstraintsError) as info:
        consistent_state(eqs, coords, {"rod.omega_z": 1.0})
    msg = str(info.value)
    assert "'extra' is a combination of" in msg
    assert "'hinge.v3'" in msg and "'hinge.w1'" in msg and "'hinge.w2'" in msg
    # Without the extra row the same state is accepted and spins about E3.
    m2, b2, A2, _, _ = _pinned_quaternion_body("revolute_only")
    joints.revolute(m2, "hinge", A2, axis=(0, 0, 1), anchor=anchor)
    q, u = consistent_state(SystemEquations(m2), coords, {"rod.omega_z": 1.0})
    assert np.abs(u[3:6] - [0, 0, 1]).max() <= 1e-12


def test_dual_basis_joints_on_a_quaternion_body_are_rejected_naming_the_body():
    """``driven_axis`` / ``fixed_angle`` need the dual Euler basis: a quaternion body is refused by name."""
    m = Model("quaternion_drive")
    b = m.add_body("wheel", 1.0, J_A, rotation="quaternion")
    for add in (lambda: joints.driven_axis(m, "motor", b, 2.0), lambda: joints.fixed_angle(m, "lock", b, index=3)):
        with pytest.raises(ModelError) as info:
            add()
        assert "'wheel'" in str(info.value) and "Euler" in str(info.value)
    assert m.joints == {}


def test_inertia_breaking_the_triangle_inequality_needs_check_inertia_false():
    from ocp_constraints.mechanics.bodies import Body

    J = np.diag([8.1e-5, 1.6e-4, 8.1e-4])          # JW's toes: 8.1e-4 > 8.1e-5 + 1.6e-4
    with pytest.raises(ModelError, match=r"toes.*not physical.*check_inertia=False"):
        Body("toes", 0.2, J, "quaternion")
    b = Model("m").add_body("toes", 0.2, J, "quaternion", check_inertia=False)
    assert np.array_equal(b.inertia, J) and "triangle inequality" in b.inertia_warning
    assert Body("ok", 1.0, np.diag([1.0, 2.0, 2.5])).inertia_warning is None
    with pytest.raises(ModelError, match="not physical"):           # negative moments stay errors
        Body("neg", 1.0, np.diag([-1.0, 2.0, 2.5]), check_inertia=False)
