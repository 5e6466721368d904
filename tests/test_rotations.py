"""Rotations: Euler and dual Euler bases (paper eqs. 9-12), angular velocity, quaternions.

Every library value is compared with an independent one: the paper's explicit eq. (11),
the defining identity ``g^i . g_j = delta^i_j``, the axial vector of ``Qdot Q^T`` with
``Qdot`` from CasADi's Jacobian of a hand-written ``Q``, orthogonality, and SciPy's
rotation matrices for the quaternion round trip.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation as SciRotation

from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.mechanics.model import Model
from ocp_constraints.mechanics.rotations import EulerSequence, UnitQuaternion, quaternion_from_rotation
from ocp_constraints.errors import SingularConfigurationError
from ocp_constraints.mechanics.state import consistent_state

PROPER = ["121", "131", "212", "232", "313", "323"]
TAIT_BRYAN = ["123", "132", "213", "231", "312", "321"]
ALL_SEQUENCES = PROPER + TAIT_BRYAN

angle = st.floats(-math.pi, math.pi, allow_nan=False)
# Second angle kept away from the singularity (|sin| or |cos| >= sin(0.05)).
proper_middle = st.floats(0.05, math.pi - 0.05)
tait_middle = st.floats(-math.pi / 2 + 0.05, math.pi / 2 - 0.05)
SETTINGS = settings(max_examples=40, deadline=None)

_a = ca.SX.sym("a", 3)
_r = ca.SX.sym("r", 3)
_w = ca.SX.sym("w", 3)


def _angles_for(seq: str):
    return st.tuples(angle, proper_middle if seq in PROPER else tait_middle, angle)


def _library_functions(seq: str) -> ca.Function:
    s = EulerSequence(seq)
    return ca.Function(
        f"lib_{seq}", [_a, _r, _w],
        [s.rotation(_a), ca.horzcat(*s.euler_basis(_a)), ca.horzcat(*s.dual_euler_basis(_a)),
         s.angular_velocity(_a, _r), s.rates(_a, _w)],
    )


LIB = {seq: _library_functions(seq) for seq in ALL_SEQUENCES}


@pytest.fixture(scope="module")
def indep_functions(indep_kinematics):
    k = indep_kinematics
    out = {}
    for seq in ALL_SEQUENCES:
        Q = k.rotation_of_sequence(seq, _a)
        omega = k.omega_from_rotation(Q, _a, _r)
        out[seq] = ca.Function(f"indep_{seq}", [_a, _r], [Q, omega, ca.jacobian(omega, _r)])
    out["eq11"] = ca.Function("eq11", [_a], [ca.horzcat(*k.dual_basis_313_eq11(_a))])
    return out


@SETTINGS
@given(angles=_angles_for("313"))
def test_dual_euler_basis_313_matches_paper_eq11(indep_functions, angles):
    """``EulerSequence("313").dual_euler_basis`` equals eq. (11) written with e_i = Q E_i."""
    lib = np.asarray(LIB["313"](angles, 0, 0)[2])
    paper = np.asarray(indep_functions["eq11"](angles))
    scale = 1 / abs(math.sin(angles[1]))  # |g^1|, |g^3| grow like cosec(theta)
    assert np.abs(lib - paper).max() <= 1e-13 * scale


@pytest.mark.parametrize("seq", ALL_SEQUENCES)
def test_dual_basis_is_reciprocal_to_euler_basis(seq):
    """``g^i . g_j = delta^i_j`` (eq. 12) for proper and Tait-Bryan sequences."""
    rng = np.random.default_rng(int(seq))
    for _ in range(20):
        a = rng.uniform(-math.pi, math.pi, 3)
        a[1] = rng.uniform(0.1, math.pi - 0.1) if seq in PROPER else rng.uniform(-1.47, 1.47)
        out = LIB[seq](a, 0, 0)
        g_lower, g_upper = np.asarray(out[1]), np.asarray(out[2])
        assert np.abs(g_upper.T @ g_lower - np.eye(3)).max() <= 1e-12


def test_313_basis_volume_is_minus_sin_theta():
    """Paper, after eq. (11): ``g = (g_1 x g_2) . g_3 = -sin(theta)`` for 3-1-3 angles."""
    seq = EulerSequence("313")
    rng = np.random.default_rng(9)
    for _ in range(20):
        a = rng.uniform(-math.pi, math.pi, 3)
        assert abs(float(seq.basis_volume(ca.DM(a))) + math.sin(a[1])) <= 1e-15


@pytest.mark.parametrize("seq", ALL_SEQUENCES)
def test_rotation_tensor_is_proper_orthogonal_and_the_stated_product(seq, indep_functions):
    """``Q = R_i(a1) R_j(a2) R_k(a3)`` (DESIGN.md), ``Q^T Q = I`` and ``det Q = 1``."""
    rng = np.random.default_rng(100 + int(seq))
    for _ in range(20):
        a = rng.uniform(-math.pi, math.pi, 3)
        Q = np.asarray(LIB[seq](a, 0, 0)[0])
        assert np.abs(Q.T @ Q - np.eye(3)).max() <= 1e-14
        assert abs(np.linalg.det(Q) - 1) <= 1e-14
        assert np.abs(Q - np.asarray(indep_functions[seq](a, 0)[0])).max() <= 1e-15


@pytest.mark.parametrize("seq", ALL_SEQUENCES)
def test_angular_velocity_is_axial_vector_of_Qdot_QT(seq, indep_functions):
    """``omega = sum rate_i g_i`` (eq. 9) equals ``axial(Qdot Q^T)``; ``rates`` inverts it (eq. 12)."""
    rng = np.random.default_rng(200 + int(seq))
    for _ in range(20):
        a = rng.uniform(-math.pi, math.pi, 3)
        a[1] = rng.uniform(0.1, math.pi - 0.1) if seq in PROPER else rng.uniform(-1.47, 1.47)
        rates = rng.normal(size=3) * 3
        omega_indep = np.asarray(indep_functions[seq](a, rates)[1]).ravel()
        out = LIB[seq](a, rates, omega_indep)
        omega_lib = np.asarray(out[3]).ravel()
        assert np.abs(omega_lib - omega_indep).max() <= 1e-13 * max(1, np.abs(rates).max())
        # The Euler basis vectors are the columns of d(omega)/d(rates).
        W = np.asarray(indep_functions[seq](a, rates)[2])
        assert np.abs(np.asarray(out[1]) - W).max() <= 1e-14
        rates_back = np.asarray(out[4]).ravel()
        assert np.abs(rates_back - rates).max() <= 1e-11 * max(1, np.abs(rates).max())


@SETTINGS
@given(angles=_angles_for("313"), rates=st.tuples(*[st.floats(-20, 20)] * 3))
def test_313_angle_rates_are_projections_on_dual_basis(indep_functions, angles, rates):
    """Paper eq. (12): ``omega . g^1 = psi'``, ``omega . g^2 = theta'``, ``omega . g^3 = phi'`` with eq. (11)."""
    omega = np.asarray(indep_functions["313"](angles, rates)[1]).ravel()
    dual = np.asarray(indep_functions["eq11"](angles))
    back = dual.T @ omega
    scale = max(1.0, np.abs(rates).max()) / abs(math.sin(angles[1]))
    assert np.abs(back - np.asarray(rates)).max() <= 1e-12 * scale
    assert np.abs(np.asarray(LIB["313"](angles, 0, omega)[4]).ravel() - np.asarray(rates)).max() <= 1e-12 * scale


# -- quaternions ------------------------------------------------------------------------
def _special_rotations() -> list[np.ndarray]:
    """Rotations that select each branch of Shepperd's method (incl. half turns)."""
    mats = [np.eye(3)]
    for axis in np.eye(3):
        mats.append(SciRotation.from_rotvec(math.pi * axis).as_matrix())
        mats.append(SciRotation.from_rotvec((math.pi - 1e-3) * axis).as_matrix())
    mats.append(SciRotation.from_rotvec(math.pi * np.array([1.0, 1.0, 1.0]) / math.sqrt(3)).as_matrix())
    mats.append(SciRotation.from_rotvec(math.pi * np.array([1.0, -2.0, 0.5]) / math.sqrt(5.25)).as_matrix())
    return mats


def test_quaternion_from_rotation_round_trips_to_the_same_rotation():
    """``UnitQuaternion().rotation(quaternion_from_rotation(R)) = R`` for random and half-turn rotations."""
    rot = UnitQuaternion()
    qs = ca.SX.sym("q", 4)
    Qf = ca.Function("Q", [qs], [rot.rotation(qs)])
    mats = list(SciRotation.random(200, random_state=7).as_matrix()) + _special_rotations()
    for R in mats:
        q = quaternion_from_rotation(R)
        assert abs(np.linalg.norm(q) - 1) <= 1e-14
        assert q[0] >= 0
        assert np.abs(np.asarray(Qf(q)) - R).max() <= 1e-14
        # SciPy's quaternion (x, y, z, w) is the same up to sign.
        ref = SciRotation.from_matrix(R).as_quat()
        ref = np.array([ref[3], ref[0], ref[1], ref[2]])
        assert min(np.abs(q - ref).max(), np.abs(q + ref).max()) <= 1e-12


def test_quaternion_rotation_matches_euler_rodrigues_form(indep_kinematics):
    """The library's entrywise ``Q(q)`` equals ``((w^2 - v.v) I + 2 v v^T + 2 w [v]x) / |q|^2``."""
    qs = ca.SX.sym("q", 4)
    f = ca.Function("f", [qs], [UnitQuaternion().rotation(qs) - indep_kinematics.quaternion_rotation(qs)])
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = rng.normal(size=4) * rng.uniform(0.2, 3)  # not unit: Q must still be a rotation
        assert np.abs(np.asarray(f(q))).max() <= 1e-14


def test_quaternion_rates_and_rates_to_omega_matrix_are_inverse(indep_kinematics):
    """``E(q) q'(q, omega) = omega``, and ``axial(Qdot Q^T) = omega`` with ``Qdot = dQ/dq . q'``."""
    rot = UnitQuaternion()
    qs, ws = ca.SX.sym("q", 4), ca.SX.sym("w", 3)
    qdot = rot.rates(qs, ws)
    omega_axial = indep_kinematics.omega_from_rotation(indep_kinematics.quaternion_rotation(qs), qs, qdot)
    f = ca.Function("f", [qs, ws], [rot.rates_to_omega_matrix(qs) @ qdot, omega_axial, ca.dot(qs, qdot)])
    rng = np.random.default_rng(11)
    for _ in range(50):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        w = rng.normal(size=3) * 5
        back, axial, norm_rate = (np.asarray(x).ravel() for x in f(q, w))
        assert np.abs(back - w).max() <= 1e-13 * 5
        assert np.abs(axial - w).max() <= 1e-13 * 5
        assert abs(norm_rate[0]) <= 1e-14 * 5  # the rates keep |q| = 1


# -- singularity detection ---------------------------------------------------------------
def _free_body_model(rotation: str) -> Model:
    m = Model("free_body")
    m.add_body("disk", 1.0, np.diag([0.25, 0.25, 0.5]), rotation=rotation)
    return m


def _coordinates(theta: float) -> dict[str, float]:
    return {"disk.x": 0.0, "disk.y": 0.0, "disk.z": 0.0, "disk.psi": 0.3, "disk.theta": theta, "disk.phi": -0.2}


def test_check_singularity_raises_for_313_near_theta_zero_and_names_body_and_angle():
    """3-1-3 at theta = 1e-6: the error names the body, the angle, and advises a quaternion."""
    seq = EulerSequence("313")
    with pytest.raises(SingularConfigurationError) as info:
        seq.check_singularity([0.3, 1e-6, -0.2], "body 'disk' at t = 0")
    msg = str(info.value)
    assert "disk" in msg and "theta" in msg and "quaternion" in msg

    eqs = SystemEquations(_free_body_model("313"))
    with pytest.raises(SingularConfigurationError) as info:
        consistent_state(eqs, _coordinates(1e-6), {})
    msg = str(info.value)
    assert "body 'disk'" in msg and "theta" in msg and "quaternion" in msg
    # The same near theta = pi.
    with pytest.raises(SingularConfigurationError):
        seq.check_singularity([0.3, math.pi - 1e-6, -0.2], "body 'disk'")


def test_check_singularity_accepts_regular_configurations():
    """No error at theta = 1.0 (3-1-3) or theta = 0 (3-2-1); 3-2-1 raises at theta = pi/2."""
    EulerSequence("313").check_singularity([0.3, 1.0, -0.2], "body 'disk'")
    eqs = SystemEquations(_free_body_model("313"))
    q, u = consistent_state(eqs, _coordinates(1.0), {})
    assert q[4] == 1.0 and np.all(u == 0)
    EulerSequence("321").check_singularity([0.3, 0.0, -0.2], "body 'rod'")
    with pytest.raises(SingularConfigurationError) as info:
        EulerSequence("321").check_singularity([0.3, math.pi / 2 - 1e-7, -0.2], "body 'rod'")
    assert "rod" in str(info.value) and "theta" in str(info.value)


def test_quaternion_from_rotation_of_a_stack_matches_scipy_matrix_by_matrix():
    """The stacked form (a robot's guess converts thousands of matrices at once) against SciPy's
    conversion, one sign convention (qw >= 0), on random rotations and the half turns where Shepperd's
    method takes each of its four branches."""
    from ocp_constraints.mechanics.rotations import quaternion_from_rotation

    R = np.concatenate([SciRotation.random(500, random_state=3).as_matrix(),
                        [np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])]])
    xyzw = SciRotation.from_matrix(R).as_quat()
    expected = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    expected *= np.where(expected[:, :1] < 0, -1.0, 1.0)
    stacked = quaternion_from_rotation(R)
    assert stacked.shape == (len(R), 4)
    # At a half turn (qw = 0) the sign is a convention: compare up to it there.
    same = np.minimum(np.abs(stacked - expected).max(axis=1), np.abs(stacked + expected).max(axis=1))
    assert same.max() < 1e-14
    one_by_one = np.array([quaternion_from_rotation(r) for r in R])
    assert np.array_equal(stacked, one_by_one)
