"""The joint library (``oc.joints``): every spatial joint, to ground and between two bodies.

Independent values used here, none of them produced by the library:

* textbook kinematics of each joint: its degrees of freedom (revolute 1, prismatic 1,
  cylindrical 2, universal 2, planar 3, weld 0, ball 3, point on a line 4), which
  relative motions it allows (relative twists computed here from ``v = vbar + omega x r``
  with positions from scipy rotation matrices), and the reciprocal loads it can carry;
* a planar four-bar linkage: closed-form loop-closure angles (Freudenstein / Norton),
  closed-form angular velocity ratios, and the pin forces of a hand Newton-Euler balance
  of the three links (a 9 x 9 linear system written from free-body diagrams);
* a slider on a rail spun at a constant rate (1-DOF hand derivation: ``s'' = Omega^2 s``,
  Coriolis force ``2 m Omega s'``, motor torque ``2 m Omega s s'``);
* two welded bodies moving as one rigid body (compound mass, center and inertia by the
  parallel-axis theorem), the weld load being the hand-computed internal load;
* a Cardan (Hooke) shaft pair: ``omega_2 / omega_1 = cos b / (1 - sin^2 b cos^2 theta_1)``;
* bodies at rest on a ball, revolute or universal joint to ground (moment balance about the
  fixed point with the parallel-axis inertia), a spinning body on a cylindrical or planar
  joint (gyroscopic moment ``Omega^2 E3 x (J E3)``), a block on an inclined prismatic joint;
* each two-body joint against its to-ground twin when the base body is welded to the
  ground (the same motion and multipliers; the base's weld load balances the joint's
  reaction on it and the base's weight).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ocp_constraints import joints
from ocp_constraints.dynamics.inverse import InverseDynamics
from ocp_constraints.errors import ModelError, RedundantConstraintsError
from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.mechanics.model import Model
from ocp_constraints.mechanics.state import consistent_state, project_positions

G = 9.81
E1, E2, E3 = np.eye(3)
KINDS = ["ball_and_socket", "revolute", "universal", "cylindrical", "prismatic", "planar", "weld", "point_on_line"]
TEXTBOOK_DOF = {"ball_and_socket": 3, "revolute": 1, "universal": 2, "cylindrical": 2, "prismatic": 1, "planar": 3,
                "weld": 0, "point_on_line": 4}
J1 = np.array([[0.11, 0.012, -0.02], [0.012, 0.09, 0.015], [-0.02, 0.015, 0.14]])
J2 = np.array([[0.07, -0.01, 0.004], [-0.01, 0.12, 0.02], [0.004, 0.02, 0.10]])


# -- helpers written without the library -----------------------------------------------------------
def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def params_of(R: np.ndarray, rotation: str) -> np.ndarray:
    """Rotation parameters of ``R`` from scipy: quaternion (w, x, y, z), 3-2-1 or 3-1-3 angles."""
    r = Rotation.from_matrix(R)
    if rotation == "quaternion":
        x, y, z, w = r.as_quat()
        return np.array([w, x, y, z])
    return r.as_euler({"321": "ZYX", "313": "ZXZ"}[rotation])


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def forward(eqs, q, u, t=0.0, inputs=()):
    udot, lam = eqs.forward_dynamics(q, u, t, list(inputs), [0.0] * len(inputs))
    return np.asarray(udot).ravel(), np.asarray(lam).ravel()


def loads(eqs, q, u, lam, t=0.0) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per load channel: force, moment about the point, point (fixed basis)."""
    out = np.asarray(eqs.loads_function(q, u, t, lam)).ravel()
    return {ch.prefix: (out[10 * i:10 * i + 3], out[10 * i + 3:10 * i + 6], out[10 * i + 6:10 * i + 9])
            for i, ch in enumerate(eqs.load_channels)}


def lam_of(eqs, lam, name):
    return lam[eqs.constraint_names.index(name)]


# -- a random assembled joint (the geometry is made consistent at random poses) --------------------
@dataclass
class Assembly:
    kind: str
    two: bool
    model: Model
    eqs: SystemEquations
    q: np.ndarray
    x1: np.ndarray     # body center of mass
    xC1: np.ndarray    # the body's joint point
    x2: np.ndarray     # base center of mass (zero for the ground)
    R2: np.ndarray     # base rotation (identity for the ground)
    n: np.ndarray      # joint axis / plane normal (fixed basis)
    a: np.ndarray      # universal: the base's arm; else a unit vector normal to n
    b: np.ndarray      # universal: the body's arm; else n x a

    @property
    def channel(self):
        return "j@body" if self.two else "j"


def build_joint(kind, model, P, C2, *, anchor, n_base, n_body, a_base, b_body, R0):
    """The joint ``kind`` between ``P`` and ``C2`` (or the ground at ``anchor``), geometry in the base/body bases."""
    if kind == "ball_and_socket":
        joints.ball_and_socket(model, "j", P, C2, anchor=anchor)
    elif kind == "revolute":
        joints.revolute(model, "j", P, axis=n_base, anchor=anchor, body_axis=n_body, other=C2)
    elif kind == "universal":
        joints.universal(model, "j", P, C2, axis=a_base, body_axis=b_body, anchor=anchor)
    elif kind == "cylindrical":
        joints.cylindrical(model, "j", P, C2, axis=n_base, body_axis=n_body, anchor=anchor)
    elif kind == "prismatic":
        joints.prismatic(model, "j", P, C2, axis=n_base, anchor=anchor, relative_rotation=R0)
    elif kind == "planar":
        joints.planar(model, "j", P, C2, normal=n_base, body_normal=n_body, anchor=anchor)
    elif kind == "weld":
        joints.weld(model, "j", P, C2, anchor=anchor, relative_rotation=R0)
    else:
        joints.point_on_line(model, "j", P, C2, axis=n_base, anchor=anchor)


def assemble(kind: str, two: bool, seed: int, rotation: str = "quaternion", base_weld: bool = False,
             applied=None) -> Assembly:
    """Random poses, then joint geometry chosen so that the joint is assembled at them.

    ``applied = (F, x_F, T)``: a force ``F`` at the body's material point now at ``x_F`` and a torque ``T``.
    """
    rng = np.random.default_rng(seed)
    R1 = Rotation.random(random_state=rng).as_matrix()
    x1 = rng.normal(size=3)
    n = unit(rng.normal(size=3))
    a = unit(np.cross(n, rng.normal(size=3)))
    b = np.cross(n, a)
    xJ = rng.normal(size=3)
    shift = {"cylindrical": n, "prismatic": n, "point_on_line": n, "planar": a - 0.5 * b}.get(kind, 0 * n)
    xC1 = xJ + rng.uniform(0.2, 0.5) * shift
    if kind == "universal":           # the cross: arm a fixed in the base, arm b in the body
        a, b = n, a
    m = Model(f"{kind}_{'two' if two else 'ground'}", gravity=(0.0, 0.0, -G))
    R2, x2, C2 = np.eye(3), np.zeros(3), None
    if two:
        R2 = Rotation.random(random_state=rng).as_matrix()
        x2 = rng.normal(size=3)
        base = m.add_body("base", 1.3, J2, rotation=rotation)
        C2 = base.point("C", R2.T @ (xJ - x2))
        if base_weld:
            joints.weld(m, "fix", base.com, anchor=x2, relative_rotation=R2)
    body = m.add_body("body", 0.9, J1, rotation=rotation)
    P = body.point("P", R1.T @ (xC1 - x1))
    build_joint(kind, m, P, C2, anchor=None if two else xJ, n_base=R2.T @ n, n_body=R1.T @ n,
                a_base=R2.T @ a, b_body=R1.T @ b, R0=R2.T @ R1)
    if applied is not None:
        F, xF, T = applied
        m.add_force("push", body.point("F", R1.T @ (xF - x1)), F)
        m.add_torque("twist", body, T)
    eqs = SystemEquations(m)
    poses = ([(x2, R2)] if two else []) + [(x1, R1)]
    q = np.concatenate([np.concatenate([x, params_of(R, rotation)]) for x, R in poses])
    return Assembly(kind, two, m, eqs, q, x1, xC1, x2, R2, n, a, b)


def free_relative_motion(A: Assembly) -> tuple[list, list]:
    """Textbook: the relative rotations and translations (at X_C1) the joint allows, fixed basis."""
    n, a, b = A.n, A.a, A.b
    return {
        "ball_and_socket": ([E1, E2, E3], []),
        "revolute": ([n], []),
        "universal": ([a, b], []),
        "cylindrical": ([n], [n]),
        "prismatic": ([], [n]),
        "planar": ([n], [a, b]),
        "weld": ([], []),
        "point_on_line": ([E1, E2, E3], [n]),
    }[A.kind]


def residual_outside(vectors, span) -> float:
    """Largest component of ``vectors`` outside ``span`` (orthogonal projection)."""
    if not span:
        return max((np.linalg.norm(v) for v in vectors), default=0.0)
    Bq, _ = np.linalg.qr(np.array(span).T)
    return max((np.linalg.norm(v - Bq @ (Bq.T @ v)) for v in vectors), default=0.0)


def relative_twist(A: Assembly, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``omega_1 - omega_2`` and the velocity of X_C1 relative to the base's material point there."""
    vb1, w1 = u[-6:-3], u[-3:]
    v_C1 = vb1 + np.cross(w1, A.xC1 - A.x1)
    if not A.two:
        return w1, v_C1
    vb2, w2 = u[0:3], u[3:6]
    return w1 - w2, v_C1 - (vb2 + np.cross(w2, A.xC1 - A.x2))


# -- textbook kinematics and loads of every joint ---------------------------------------------------
@pytest.mark.parametrize("two", [False, True], ids=["to_ground", "two_bodies"])
@pytest.mark.parametrize("kind", KINDS)
def test_degrees_of_freedom_equal_the_textbook_count(kind, two):
    """nq minus the rank of the constraint Jacobian, at velocity and at position level (3-2-1 angles:
    nq = nu; the quaternion bodies of the next test give the velocity-level count too)."""
    A = assemble(kind, two, 2, "321")
    G_, _, phi, _, phi_q = (np.asarray(x) for x in A.eqs.constraint_functions(A.q, np.zeros(A.eqs.nu), 0.0, []))
    assert np.abs(phi).max() < 1e-12, "the geometry is assembled, so every position form vanishes"
    base_dof = 6 if two else 0
    assert A.eqs.nu - np.linalg.matrix_rank(G_, tol=1e-9) - base_dof == TEXTBOOK_DOF[kind]
    assert A.eqs.nq - np.linalg.matrix_rank(phi_q, tol=1e-9) - base_dof == TEXTBOOK_DOF[kind]
    # the position forms are the time integrals of the constraints (at random, even inadmissible, speeds)
    mismatch = A.eqs.position_form_mismatch(A.q, np.random.default_rng(2).normal(size=A.eqs.nu), 0.0, [])
    assert np.abs(np.asarray(mismatch)).max() < 1e-12


@pytest.mark.parametrize("two", [False, True], ids=["to_ground", "two_bodies"])
@pytest.mark.parametrize("kind", KINDS)
def test_allowed_relative_motion_and_reciprocal_loads_are_the_textbook_ones(kind, two):
    A = assemble(kind, two, seed=7)
    eqs = A.eqs
    G_ = np.asarray(eqs.constraint_functions(A.q, np.zeros(eqs.nu), 0.0, [])[0])
    rot_free, trans_free = free_relative_motion(A)
    assert eqs.nu - np.linalg.matrix_rank(G_, tol=1e-9) - (6 if two else 0) == TEXTBOOK_DOF[kind]
    # every admissible motion (null space of G) moves the body relative to the base only as the joint allows
    Z = np.linalg.svd(G_)[2][np.linalg.matrix_rank(G_):].T
    twists = [relative_twist(A, z) for z in Z.T]
    assert residual_outside([w for w, _ in twists], rot_free) < 1e-12
    assert residual_outside([v for _, v in twists], trans_free) < 1e-12
    assert np.linalg.matrix_rank(np.array([np.concatenate(t) for t in twists]).reshape(-1, 6), tol=1e-9) \
        == TEXTBOOK_DOF[kind]
    # each multiplier's load on the body (force at X_C1, moment about it) is reciprocal to those motions
    wrenches = []
    for k in range(eqs.nc):
        lam = np.eye(eqs.nc)[k]
        ld = loads(eqs, A.q, np.zeros(eqs.nu), lam)
        F, M, at = ld[A.channel]
        np.testing.assert_allclose(at, A.xC1, atol=1e-12)
        assert all(abs(F @ t) < 1e-12 for t in trans_free) and all(abs(M @ r) < 1e-12 for r in rot_free)
        wrenches.append(np.concatenate([F, M]))
        if two:   # Newton's third law: the base gets the opposite load (moments about X_C1)
            F2, M2, at2 = ld["j@base"]
            np.testing.assert_allclose(F2, -F, atol=1e-12)
            np.testing.assert_allclose(M2 + np.cross(at2 - A.xC1, F2), -M, atol=1e-12)
    assert np.linalg.matrix_rank(np.array(wrenches), tol=1e-9) == 6 - TEXTBOOK_DOF[kind] == eqs.nc
    if kind == "universal":   # the constraint moment is normal to both arms of the cross
        lam = np.eye(eqs.nc)[eqs.constraint_names.index("j.w")]
        M = loads(eqs, A.q, np.zeros(eqs.nu), lam)[A.channel][1]
        assert abs(M @ A.a) < 1e-12 and abs(M @ A.b) < 1e-12
        np.testing.assert_allclose(M, np.cross(A.a, A.b), atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_body_on_a_joint_to_ground_obeys_newton_euler_with_the_textbook_reaction(kind):
    """Hand Newton-Euler: the joint point accelerates and the body turns only as the joint allows;
    the reaction is a force normal to the free translations at the joint point and a moment
    normal to the free rotations. Random free motion (at rest for the universal joint, whose
    free axes turn), gravity, an applied force and torque: 6 equations, 6 unknowns."""
    F_app, T_app = np.array([1.5, -0.7, 2.0]), np.array([-0.4, 0.9, 0.3])
    rng = np.random.default_rng(32)
    x_F = rng.normal(size=3)
    A = assemble(kind, False, seed=31, applied=(F_app, x_F, T_app))
    R1 = Rotation.from_quat(np.roll(A.q[3:7], -1)).as_matrix()      # scipy's (x, y, z, w) order
    m_, J = 0.9, R1 @ J1 @ R1.T
    rot_free, trans_free = free_relative_motion(A)
    w = np.zeros(3) if kind == "universal" else sum((rng.normal() * r for r in rot_free), np.zeros(3))
    v_P = sum((rng.normal() * t for t in trans_free), np.zeros(3))
    r = A.x1 - A.xC1
    u = np.concatenate([v_P + np.cross(w, r), w])
    comp = lambda span: [c for c in np.linalg.svd(np.array(span).reshape(-1, 3))[2][len(span):]]  # noqa: E731
    F_dirs, M_dirs = comp(trans_free), comp(rot_free)
    cols = ([np.concatenate([m_ * t, np.zeros(3)]) for t in trans_free]
            + [np.concatenate([m_ * np.cross(rr, r), J @ rr]) for rr in rot_free]
            + [np.concatenate([-f, np.cross(r, f)]) for f in F_dirs]          # -(x_P - x_G) x F
            + [np.concatenate([np.zeros(3), -h]) for h in M_dirs])
    g = np.array([0.0, 0.0, -G])
    rhs = np.concatenate([m_ * g + F_app - m_ * np.cross(w, np.cross(w, r)),
                          T_app + np.cross(x_F - A.x1, F_app) - np.cross(w, J @ w)])
    z = np.linalg.solve(np.array(cols).T, rhs)
    nT, nR, nF = len(trans_free), len(rot_free), len(F_dirs)
    alpha = sum((z[nT + i] * rr for i, rr in enumerate(rot_free)), np.zeros(3))
    a_G = sum((z[i] * t for i, t in enumerate(trans_free)), np.zeros(3)) + np.cross(alpha, r) \
        + np.cross(w, np.cross(w, r))
    F = sum((z[nT + nR + i] * f for i, f in enumerate(F_dirs)), np.zeros(3))
    M = sum((z[nT + nR + nF + i] * h for i, h in enumerate(M_dirs)), np.zeros(3))
    udot, lam = forward(A.eqs, A.q, u)
    np.testing.assert_allclose(udot, np.concatenate([a_G, alpha]), rtol=1e-10, atol=1e-10)
    F_lib, M_lib, _ = loads(A.eqs, A.q, u, lam)["j"]
    np.testing.assert_allclose(F_lib, F, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(M_lib, M, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "weld"])
def test_two_body_joint_on_a_welded_base_moves_and_loads_like_its_to_ground_twin(kind):
    """Base welded to the ground at a random pose: the same follower motion and multipliers as
    the to-ground joint; the base's weld load balances the joint's reaction on it and its weight."""
    two = assemble(kind, True, seed=11, base_weld=True)
    one = assemble(kind, False, seed=11)            # same rng stream: same body, axes and joint point
    rng = np.random.default_rng(3)
    rot_free, trans_free = free_relative_motion(one)
    # a random admissible motion of the body: rotation and translation the joint allows
    w = sum((rng.normal() * r for r in rot_free), np.zeros(3))
    v_C1 = sum((rng.normal() * t for t in trans_free), np.zeros(3))
    u1 = np.concatenate([v_C1 + np.cross(w, one.x1 - one.xC1), w])
    np.testing.assert_allclose(two.q[7:], one.q, atol=0, err_msg="the body's pose is the same draw")
    u2 = np.concatenate([np.zeros(6), u1])
    ud1, lam1 = forward(one.eqs, one.q, u1)
    ud2, lam2 = forward(two.eqs, two.q, u2)
    np.testing.assert_allclose(ud2[:6], 0, atol=1e-10)
    np.testing.assert_allclose(ud2[6:], ud1, rtol=1e-10, atol=1e-10)
    # the joint's load on the body (the multipliers differ: the base's directions are other unit vectors)
    ld1, ld2 = loads(one.eqs, one.q, u1, lam1)["j"], loads(two.eqs, two.q, u2, lam2)
    for k in range(3):
        np.testing.assert_allclose(ld2["j@body"][k], ld1[k], rtol=1e-10, atol=1e-10)
    # the base at rest: weld load + the joint's reaction + its weight = 0 (forces; moments about its center)
    Fw, Mw, pw = ld2["fix"]
    Fr, Mr, pr = ld2["j@base"]
    np.testing.assert_allclose(Fw + Fr + 1.3 * np.array([0, 0, -G]), 0, atol=1e-10)
    np.testing.assert_allclose(Mw + np.cross(pw - two.x2, Fw) + Mr + np.cross(pr - two.x2, Fr), 0, atol=1e-10)


# -- a planar four-bar linkage: revolute joints between bodies ----------------------------------------
FOURBAR = dict(a=0.3, b=0.8, c=0.6, d=0.7, m2=0.5, m3=1.2, m4=0.9)   # crank, coupler, rocker, ground (m, kg)
COUPLER_LOAD, COUPLER_LOAD_AT = np.array([3.0, -2.0, 0.0]), np.array([0.1, 0.05, 0.0])


def fourbar_closed_form(t2: float, branch: int = -1) -> tuple[float, float]:
    """Loop-closure angles of coupler and rocker (Norton, *Design of Machinery*, eqs. 4.10-4.13)."""
    a, b, c, d = (FOURBAR[k] for k in "abcd")
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    K4, K5 = d / b, (c * c - d * d - a * a - b * b) / (2 * a * b)
    A, B, C = math.cos(t2) - K1 - K2 * math.cos(t2) + K3, -2 * math.sin(t2), K1 - (K2 + 1) * math.cos(t2) + K3
    D, E, F = math.cos(t2) - K1 + K4 * math.cos(t2) + K5, -2 * math.sin(t2), K1 + (K4 - 1) * math.cos(t2) + K5
    t4 = 2 * math.atan2(-B + branch * math.sqrt(B * B - 4 * A * C), 2 * A)
    t3 = 2 * math.atan2(-E + branch * math.sqrt(E * E - 4 * D * F), 2 * D)
    return t3, t4


def _rod_inertia(m, L):
    return np.diag([1e-3, m * L * L / 12 + 5e-4, m * L * L / 12 + 5e-4])


def fourbar_model(closing: str = "point_on_line") -> Model:
    """Crank (pivot at the origin), coupler, rocker (pivot at (d, 0, 0)); gravity -E2, a load on the coupler.

    Pins A (ground-crank), B (crank-coupler), C (coupler-rocker) are revolute joints; the ground
    pin D of the rocker is a point on a line along E3: its other three components are already
    imposed by A, B, C (a spatial loop of four revolutes is over-constrained by 3).
    """
    a, b, c, d = (FOURBAR[k] for k in "abcd")
    m = Model("fourbar", gravity=(0.0, -G, 0.0))
    crank = m.add_body("crank", FOURBAR["m2"], _rod_inertia(FOURBAR["m2"], a), rotation="321")
    coupler = m.add_body("coupler", FOURBAR["m3"], _rod_inertia(FOURBAR["m3"], b), rotation="321")
    rocker = m.add_body("rocker", FOURBAR["m4"], _rod_inertia(FOURBAR["m4"], c), rotation="321")
    joints.revolute(m, "A", crank.point("O", [-a / 2, 0, 0]), axis=E3, anchor=(0, 0, 0))
    joints.revolute(m, "B", coupler.point("B", [-b / 2, 0, 0]), axis=E3, other=crank.point("B", [a / 2, 0, 0]))
    joints.revolute(m, "C", rocker.point("C", [c / 2, 0, 0]), axis=E3, other=coupler.point("C", [b / 2, 0, 0]))
    if closing == "point_on_line":
        joints.point_on_line(m, "D", rocker.point("D", [-c / 2, 0, 0]), axis=E3, anchor=(d, 0, 0))
    else:
        joints.revolute(m, "D", rocker.point("D", [-c / 2, 0, 0]), axis=E3, anchor=(d, 0, 0))
    m.add_force("load", coupler.point("K", COUPLER_LOAD_AT), COUPLER_LOAD)
    m.add_torque("motor", crank, m.add_input("tau") * ca.DM(E3))
    return m


def fourbar_coordinates(t2: float) -> dict[str, float]:
    a, b, c, d = (FOURBAR[k] for k in "abcd")
    t3, t4 = fourbar_closed_form(t2)
    e = lambda t: np.array([math.cos(t), math.sin(t)])  # noqa: E731
    centers = {"crank": a / 2 * e(t2), "coupler": a * e(t2) + b / 2 * e(t3), "rocker": np.array([d, 0]) + c / 2 * e(t4)}
    angles = {"crank": t2, "coupler": t3, "rocker": t4}
    out = {}
    for body, (x, y) in centers.items():
        out.update({f"{body}.x": x, f"{body}.y": y, f"{body}.z": 0.0, f"{body}.psi": angles[body],
                    f"{body}.theta": 0.0, f"{body}.phi": 0.0})
    return out


def test_four_revolute_joints_in_a_planar_loop_are_reported_redundant():
    eqs = SystemEquations(fourbar_model(closing="revolute"))
    with pytest.raises(RedundantConstraintsError) as err:
        consistent_state(eqs, fourbar_coordinates(0.9), {"crank.psi_dot": 1.0})
    assert str(err.value).count("is a combination of") == 3   # 6*3 - 5*4 = -2 by Gruebler; the loop has 1 DOF


def test_four_bar_positions_and_speeds_follow_the_closed_form_kinematics():
    eqs = SystemEquations(fourbar_model())
    names = eqs.model.coordinate_names
    rng = np.random.default_rng(5)
    for t2 in (0.4, 1.3, 2.5, 4.0):
        exact = fourbar_coordinates(t2)
        guess = np.array([exact[n] for n in names]) + 0.02 * rng.normal(size=eqs.nq)
        q = project_positions(eqs, guess, 0.0)           # Gauss-Newton on the joints' position forms
        moved = fourbar_coordinates(q[names.index("crank.psi")])   # where the crank ended up
        np.testing.assert_allclose(q, [moved[n] for n in names], atol=1e-10)
        w2 = 1.7
        q0, u0 = consistent_state(eqs, moved, {"crank.psi_dot": w2})
        a, b, c = FOURBAR["a"], FOURBAR["b"], FOURBAR["c"]
        t2m, t3, t4 = moved["crank.psi"], moved["coupler.psi"], moved["rocker.psi"]
        w3 = a * w2 * math.sin(t4 - t2m) / (b * math.sin(t3 - t4))
        w4 = a * w2 * math.sin(t2m - t3) / (c * math.sin(t4 - t3))
        speeds = dict(zip(eqs.model.speed_names, u0))
        assert speeds["coupler.omega_z"] == pytest.approx(w3, abs=1e-10)
        assert speeds["rocker.omega_z"] == pytest.approx(w4, abs=1e-10)
        np.testing.assert_allclose([speeds["rocker.vbar_x"], speeds["rocker.vbar_y"]],
                                   c / 2 * w4 * np.array([-math.sin(t4), math.cos(t4)]), atol=1e-10)
        assert max(abs(speeds[f"{b_}.{s}"]) for b_ in ("crank", "coupler", "rocker")
                   for s in ("vbar_z", "omega_x", "omega_y")) < 1e-12


def test_four_bar_static_pin_forces_equal_a_hand_newton_euler_balance():
    eqs = SystemEquations(fourbar_model())
    names = eqs.model.coordinate_names
    for t2 in (0.4, 1.3, 2.5):
        x = fourbar_coordinates(t2)
        q = np.array([x[n] for n in names])
        res = InverseDynamics(eqs).solve([0.0], q[None], np.zeros((1, eqs.nu)), np.zeros((1, eqs.nu)))
        lam, tau = res.lam[0], res.inputs[0, 0]
        ld = loads(eqs, q, np.zeros(eqs.nu), lam)
        # hand balance of the three links (planar free-body diagrams), unknowns
        # R_A (ground on crank), R_B (crank on coupler), R_C (coupler on rocker), R_D (ground on rocker), tau
        a, b, c, d = (FOURBAR[k] for k in "abcd")
        t3, t4 = x["coupler.psi"], x["rocker.psi"]
        e = lambda t: np.array([math.cos(t), math.sin(t)])  # noqa: E731
        cr = lambda r, f: r[0] * f[1] - r[1] * f[0]          # noqa: E731
        g = np.array([0.0, -G])
        xO, xB, xD = np.zeros(2), a * e(t2), np.array([d, 0.0])
        xC = xB + b * e(t3)
        xG2, xG3, xG4 = a / 2 * e(t2), xB + b / 2 * e(t3), xD + c / 2 * e(t4)
        Rz = Rotation.from_euler("z", t3).as_matrix()[:2, :2]
        xK, P = xG3 + Rz @ COUPLER_LOAD_AT[:2], COUPLER_LOAD[:2]
        Mx = np.zeros((9, 9))
        rhs = np.zeros(9)
        I2 = np.eye(2)
        Mx[0:2, 0:2], Mx[0:2, 2:4] = I2, -I2                               # crank forces
        rhs[0:2] = -FOURBAR["m2"] * g
        Mx[2, 2:4] = [(xB - xO)[1], -(xB - xO)[0]]                         # cr(xB - xO, -R_B)
        Mx[2, 8] = 1.0
        rhs[2] = -cr(xG2 - xO, FOURBAR["m2"] * g)
        Mx[3:5, 2:4], Mx[3:5, 4:6] = I2, -I2                               # coupler forces
        rhs[3:5] = -FOURBAR["m3"] * g - P
        Mx[5, 4:6] = [(xC - xB)[1], -(xC - xB)[0]]                         # cr(xC - xB, -R_C)
        rhs[5] = -cr(xG3 - xB, FOURBAR["m3"] * g) - cr(xK - xB, P)
        Mx[6:8, 4:6], Mx[6:8, 6:8] = I2, I2                                # rocker forces
        rhs[6:8] = -FOURBAR["m4"] * g
        Mx[8, 4:6] = [-(xC - xD)[1], (xC - xD)[0]]                         # cr(xC - xD, R_C)
        rhs[8] = -cr(xG4 - xD, FOURBAR["m4"] * g)
        hand = np.linalg.solve(Mx, rhs)
        RA, RB, RC, RD = hand[0:2], hand[2:4], hand[4:6], hand[6:8]
        for channel, R in (("A", RA), ("B@coupler", RB), ("B@crank", -RB), ("C@rocker", RC),
                           ("C@coupler", -RC), ("D", RD)):
            F, M, _ = ld[channel]
            np.testing.assert_allclose(F, [*R, 0.0], atol=1e-9, err_msg=channel)
            np.testing.assert_allclose(M, 0.0, atol=1e-9, err_msg=channel)   # no out-of-plane load
        assert tau == pytest.approx(hand[8], abs=1e-9)


# -- prismatic joint between two bodies: a slider on a spinning rail ----------------------------------
RAIL_OMEGA, SLIDER_MASS, RAIL_MASS = 1.5, 0.7, 2.0
SLIDER_J = np.array([[0.02, 0.0, 0.004], [0.0, 0.03, 0.0], [0.004, 0.0, 0.025]])   # a product of inertia


def rail_model() -> Model:
    """A rail turned about E3 at the constant rate Omega (revolute hub + drive), a slider on a prismatic
    joint along the rail's e1 through the hub; gravity -E3."""
    m = Model("rail", gravity=(0.0, 0.0, -G))
    rail = m.add_body("rail", RAIL_MASS, np.diag([0.2, 0.3, 0.4]), rotation="321")
    slider = m.add_body("slider", SLIDER_MASS, SLIDER_J, rotation="321")
    joints.revolute(m, "hub", rail.com, axis=E3)
    joints.driven_axis(m, "hub", rail, RAIL_OMEGA, index=1)
    joints.prismatic(m, "slide", slider.com, rail.com, axis=(1, 0, 0))
    return m


def rail_state(eqs, angle, s, s_dot):
    er, et = np.array([math.cos(angle), math.sin(angle), 0.0]), np.array([-math.sin(angle), math.cos(angle), 0.0])
    x = {"rail.psi": angle, "slider.psi": angle, "slider.x": s * er[0], "slider.y": s * er[1]}
    q = np.array([x.get(n, 0.0) for n in eqs.model.coordinate_names])
    u = np.concatenate([np.zeros(3), RAIL_OMEGA * E3, s_dot * er + s * RAIL_OMEGA * et, RAIL_OMEGA * E3])
    return q, u, er, et


def test_slider_on_a_spinning_rail_matches_the_one_dof_hand_derivation():
    """``m (s'' - Omega^2 s) = 0``; the rail pushes with ``2 m Omega s'`` (Coriolis) along e_theta and
    ``m g`` up, and keeps the slider from tilting with ``Omega^2 E3 x (J E3)``; the motor torque is
    ``d/dt (m s^2 Omega) = 2 m Omega s s'``."""
    eqs = SystemEquations(rail_model())
    W, ms = RAIL_OMEGA, SLIDER_MASS
    for angle, s, s_dot in ((0.3, 0.4, 0.9), (2.0, -0.25, 0.3), (4.1, 0.8, -1.1)):
        q, u, er, et = rail_state(eqs, angle, s, s_dot)
        udot, lam = forward(eqs, q, u)
        np.testing.assert_allclose(udot[:6], 0, atol=1e-10)                       # the rail turns steadily
        np.testing.assert_allclose(udot[6:9], 2 * W * s_dot * et, atol=1e-10)   # s'' = Omega^2 s, Coriolis
        np.testing.assert_allclose(udot[9:12], 0, atol=1e-10)
        assert lam_of(eqs, lam, "slide.n1") == pytest.approx(2 * ms * W * s_dot, abs=1e-10)   # along e_theta
        assert lam_of(eqs, lam, "slide.n2") == pytest.approx(ms * G, abs=1e-10)               # along E3
        Q = Rotation.from_euler("z", angle).as_matrix()
        M = W * W * np.cross(E3, Q @ SLIDER_J @ Q.T @ E3)
        np.testing.assert_allclose([lam_of(eqs, lam, f"slide.w{k}") for k in (1, 2, 3)], Q.T @ M, atol=1e-10)
        assert lam_of(eqs, lam, "hub.drive") == pytest.approx(2 * ms * W * s * s_dot, abs=1e-10)
        F_hub = loads(eqs, q, u, lam)["hub"][0]
        np.testing.assert_allclose(F_hub, 2 * ms * W * s_dot * et + (ms + RAIL_MASS) * G * E3, atol=1e-10)


def test_slider_on_a_spinning_rail_simulates_the_cosh_law():
    from ocp_constraints.dynamics.simulate import simulate

    eqs = SystemEquations(rail_model())
    s0, v0, W = 0.2, -0.1, RAIL_OMEGA
    q0, u0, _, _ = rail_state(eqs, 0.0, s0, v0)
    traj = simulate(eqs, q0, u0, 1.0)
    names = eqs.model.coordinate_names
    s = np.hypot(traj.q[:, names.index("slider.x")], traj.q[:, names.index("slider.y")])
    s_exact = s0 * np.cosh(W * traj.t) + v0 / W * np.sinh(W * traj.t)
    np.testing.assert_allclose(s, np.abs(s_exact), atol=1e-8)
    np.testing.assert_allclose(traj.q[:, names.index("rail.psi")], W * traj.t, atol=1e-8)
    s_dot = s0 * W * np.sinh(W * traj.t) + v0 * np.cosh(W * traj.t)
    np.testing.assert_allclose(traj.lam[:, eqs.constraint_names.index("hub.drive")],
                               2 * SLIDER_MASS * W * s_exact * s_dot, atol=1e-7)


# -- weld between two bodies: one rigid body ---------------------------------------------------------
def test_two_welded_bodies_move_as_one_rigid_body_and_the_weld_carries_the_internal_load():
    rng = np.random.default_rng(21)
    mA, mB = 1.1, 0.6
    RA, RB = (Rotation.random(random_state=rng).as_matrix() for _ in range(2))
    xA, xB, xW = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    m = Model("welded", gravity=(0.0, 0.0, -G))
    A = m.add_body("A", mA, J1, rotation="quaternion")
    B = m.add_body("B", mB, J2, rotation="quaternion")
    joints.weld(m, "glue", B.point("W", RB.T @ (xW - xB)), A.point("W", RA.T @ (xW - xA)), relative_rotation=RA.T @ RB)
    rA_F = rng.normal(size=3)                          # body-basis offset of the force on A
    FA, TB = np.array([2.0, -1.0, 0.5]), np.array([0.3, 0.2, -0.4])
    m.add_force("push", A.point("F", rA_F), FA)
    m.add_torque("twist", B, TB)
    eqs = SystemEquations(m)
    q = np.concatenate([xA, params_of(RA, "quaternion"), xB, params_of(RB, "quaternion")])
    w, vA = rng.normal(size=3), rng.normal(size=3)
    u = np.concatenate([vA, w, vA + np.cross(w, xB - xA), w])
    udot, lam = forward(eqs, q, u)
    # the compound body: mass, center, inertia about the center by the parallel-axis theorem
    M = mA + mB
    xG = (mA * xA + mB * xB) / M
    JA, JB = RA @ J1 @ RA.T, RB @ J2 @ RB.T
    par = lambda m_, d: m_ * (d @ d * np.eye(3) - np.outer(d, d))  # noqa: E731
    JG = JA + par(mA, xA - xG) + JB + par(mB, xB - xG)
    g = np.array([0.0, 0.0, -G])
    xF = xA + RA @ rA_F
    aG = (FA + M * g) / M
    alpha = np.linalg.solve(JG, np.cross(xF - xG, FA) + TB - np.cross(w, JG @ w))
    acc = lambda x: aG + np.cross(alpha, x - xG) + np.cross(w, np.cross(w, x - xG))  # noqa: E731
    np.testing.assert_allclose(udot, np.concatenate([acc(xA), alpha, acc(xB), alpha]), rtol=1e-10, atol=1e-10)
    # the internal load on B (at the weld point): what B's own Newton-Euler balance needs
    F_int = mB * acc(xB) - mB * g
    M_int = JB @ alpha + np.cross(w, JB @ w) - TB - np.cross(xW - xB, F_int)
    ld = loads(eqs, q, u, lam)
    np.testing.assert_allclose(ld["glue@B"][0], F_int, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(ld["glue@B"][1], M_int, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(ld["glue@A"][0], -F_int, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(ld["glue@A"][1], -M_int, rtol=1e-10, atol=1e-10)


# -- universal joint between two bodies: the Cardan shaft ---------------------------------------------
@pytest.mark.parametrize("beta", [0.3, 0.6])
def test_cardan_shafts_have_the_hooke_joint_speed_ratio(beta):
    """Input shaft on a revolute about E1, output shaft at angle beta joined by a universal joint
    at the origin and held on its axis by a point on a line:
    ``omega_2 / omega_1 = cos b / (1 - sin^2 b cos^2 theta_1)``, theta_1 from the cross arm in the shafts' plane."""
    L = 0.5
    s2 = np.array([math.cos(beta), math.sin(beta), 0.0])
    m = Model("cardan", gravity=(0.0, 0.0, 0.0))
    J = np.diag([0.01, 0.02, 0.02])
    shaft1 = m.add_body("in", 1.0, J, rotation="quaternion")
    shaft2 = m.add_body("out", 1.0, J, rotation="quaternion")
    U1 = shaft1.point("U", [L / 2, 0, 0])
    joints.revolute(m, "bearing", U1, axis=E1)
    # cross: arm a = e2 of the input shaft, arm b = e3 of the output shaft (normal to a and to s2)
    joints.universal(m, "cross", shaft2.point("U", [-L / 2, 0, 0]), U1, axis=E2, body_axis=E3)
    joints.point_on_line(m, "support", shaft2.point("F", [L / 2, 0, 0]), axis=s2, anchor=L * s2)
    eqs = SystemEquations(m)
    R2 = Rotation.from_euler("z", beta).as_matrix()
    names = m.coordinate_names
    rng = np.random.default_rng(2)
    for t1 in (0.0, 0.5, 1.2, math.pi / 2, 2.4):
        R1 = Rotation.from_rotvec(t1 * E1).as_matrix()
        t2 = math.atan2(math.tan(t1), math.cos(beta)) if abs(math.cos(t1)) > 1e-12 else t1
        R2t = Rotation.from_rotvec(t2 * s2).as_matrix() @ R2
        guess = np.concatenate([[-L / 2, 0, 0], params_of(R1, "quaternion"), L / 2 * s2, params_of(R2t, "quaternion")])
        q = project_positions(eqs, guess + 1e-3 * rng.normal(size=eqs.nq), 0.0)
        q0, u0 = consistent_state(eqs, dict(zip(names, q)), {"in.omega_x": 2.0})
        Q1 = Rotation.from_quat(np.roll(q0[3:7], -1)).as_matrix()
        a = Q1 @ E2
        theta1 = math.atan2(a[2], a[1])
        w1, w2 = u0[3:6] @ E1, u0[9:12] @ s2
        assert w1 == pytest.approx(2.0, abs=1e-12)
        ratio = math.cos(beta) / (1 - math.sin(beta) ** 2 * math.cos(theta1) ** 2)
        assert w2 / w1 == pytest.approx(ratio, abs=1e-10)
        np.testing.assert_allclose(np.cross(u0[9:12], s2), 0, atol=1e-10)      # the output turns about its axis


# -- names, descriptions and bad input ---------------------------------------------------------------
def test_describe_lists_every_multiplier_with_the_load_component_it_is():
    m = fourbar_model()
    b = m.body("coupler")
    m.add_constraint("hand.slide", ca.dot(ca.DM(E3), b.points["K"].v), joint="hand")   # written by hand
    text = m.describe()
    for c in m.constraints:
        assert f"{c.name}.lambda: " in text
    lines = {ln.split(".lambda: ")[0].strip(): ln.split(".lambda: ")[1] for ln in text.splitlines() if ".lambda: " in ln}
    assert lines["A.v1"].startswith("force component along E1 (fixed basis) on 'crank' at crank.O")
    assert lines["A.w1"] == "moment component on 'crank' about (1, 0, 0) (fixed basis), normal to the axis (0, 0, 1)"
    assert lines["B.v2"] == ("force component along E2 (fixed basis) on 'coupler' at coupler.B; "
                             "the opposite on 'crank' (Newton's third law)")
    assert "(basis of body 'crank', turning with it)" in lines["B.w1"]
    assert lines["D.n1"].startswith("force component along (1, 0, 0) (fixed basis) on 'rocker' at rocker.D")
    assert lines["hand.slide"] == "force lambda x [0.0, 0.0, 1.0] (fixed basis) on 'coupler' at coupler.K"
    assert "joint 'B' (between two bodies, equal and opposite loads)" in text
    assert "B@crank" in text and "B@coupler" in text


def test_universal_and_prismatic_multipliers_are_described_in_their_frames():
    A = assemble("universal", True, seed=3)
    text = A.model.describe()
    assert "j.w.lambda: moment component on 'body' about a x b, a = " in text and "(basis of body 'base', turning with it)" in text
    P = assemble("prismatic", True, seed=3).model.describe()
    for k in (1, 2, 3):
        assert f"j.w{k}.lambda: moment component on 'body' about the base's e{k} (basis of body 'base'" in P
    assert "j.n1.lambda: force component along" in P and "acts along the same line" in P


def test_fixed_angle_and_drive_twice_in_one_joint_get_distinct_names():
    m = Model("locks")
    b = m.add_body("b", 1.0, np.diag([0.1, 0.2, 0.25]), rotation="321")
    joints.ball_and_socket(m, "hip", b.point("H", [0, 0, 0.3]))
    joints.fixed_angle(m, "hip", b, index=2, value=0.0)
    joints.fixed_angle(m, "hip", b, index=3, value=0.0)
    joints.driven_axis(m, "hip", b, 1.0, index=1)
    assert [c.name for c in m.joint("hip").constraints][3:] == ["hip.lock", "hip.lock3", "hip.drive"]
    text = m.describe()
    assert "hip.lock3.lambda: moment component along g^3 (dual Euler basis of body 'b')" in text
    assert "hip.drive.lambda: motor torque: moment component along g^1" in text
    with pytest.raises(ModelError, match="already has a constraint named 'hip.lock'"):
        joints.fixed_angle(m, "hip", b, index=2, suffix="lock")


def test_bad_joint_input_is_rejected_naming_the_joint():
    m = Model("bad")
    b1 = m.add_body("b1", 1.0, np.diag([0.1, 0.2, 0.25]), rotation="quaternion")
    b2 = m.add_body("b2", 1.0, np.diag([0.1, 0.2, 0.25]), rotation="quaternion")
    P, Q, R = b1.point("P", [0, 0, 0.1]), b1.point("Q", [0, 0.1, 0]), b2.point("R", [0.1, 0, 0])
    with pytest.raises(ModelError, match="joint 'j': a joint between two bodies needs points of two different"):
        joints.revolute(m, "j", P, other=Q)
    with pytest.raises(ModelError, match="joint 'j': anchor is for a joint to ground"):
        joints.weld(m, "j", P, R, anchor=(1, 0, 0))
    with pytest.raises(ModelError, match="joint 'j': relative_rotation must be a 3x3 rotation matrix"):
        joints.prismatic(m, "j", P, R, relative_rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ModelError, match="joint 'j': axis must be a finite non-zero 3-vector"):
        joints.cylindrical(m, "j", P, R, axis=(0, 0, 0))
    with pytest.raises(ModelError, match="joint 'j': anchor must be 3 finite numbers"):
        joints.planar(m, "j", P, anchor=(0, np.nan, 0))
    with pytest.raises(ModelError, match="joint 'j': anchor must be 3 numbers, got \\(1, 2\\)"):
        joints.ball_and_socket(m, "j", P, anchor=(1, 2))
    with pytest.raises(ModelError, match="joint 'j': body_axis must be 3 numbers"):
        joints.universal(m, "j", P, R, body_axis="up")
    assert not m.joints, "a rejected joint adds nothing"
