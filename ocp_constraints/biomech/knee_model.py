"""The two-body knee of the paper (sec. 6, Figs. 7-8) on the JW implant geometry.

Bodies and basis. ``femur`` (the femoral component) is *held*; ``tibia`` (the tibial
tray) moves relative to it. The fixed basis is the femoral-component frame of the JW
model turned by ``S = [-Y, X, Z]`` (:data:`ocp_constraints.biomech.knee_contact.S`): ``E1``
along the femur's long axis (distal), ``E2`` posterior, ``E3`` medial (right knee; the
flexion axis). Because the femur is held at the identity, the tibia's own 3-2-1 angles
*are* the paper's relative angles: ``Q_T = R3(psi) R2(theta) R1(phi)`` with

* ``psi``: flexion-extension about ``g_1 = E3``, the femur's medio-lateral axis
  (``psi > 0`` is flexion: the tibia's distal end moves posterior);
* ``theta``: varus-valgus about the floating axis ``g_2 = R3(psi) E2``;
* ``phi``: internal-external rotation about ``g_3 = Q_T E1``, the tibia's long axis.

For 3-2-1 angles ``g_2`` is perpendicular to ``g_1`` and ``g_3``, so ``g_2 = g^2``.

The JW model's knee (``CustomJoint knee``: parent the tray F, child the femoral
component M) uses the *opposite* description, femur relative to tray,
``R_FM = Rz(flexion) Rx(adduction) R_{-y}(rotation)``, ``p_FM = (tx, ty, tz)`` (tray
frame). In our basis ``S^T R_FM S = R3(flexion) R2(adduction) R1(rotation)``, so the
tibia relative to the femur is ``Q_T = (S^T R_FM S)^T = R1(-rotation) R2(-adduction)
R3(-flexion)``, which :func:`tibia_angles` decomposes, in general, into the paper's
3-2-1 angles (``psi = -flexion`` when adduction = rotation = 0, as in the gait data).
The tray origin is ``O_T = -Q_T S^T p_FM = -Q_T (-ty, tx, tz)`` (the femoral origin is
the fixed origin).

Constraints.

* ``femur_fixed``: the femoral origin stays at the origin, the femur's angles at zero.
* ``knee_medial.n``, ``knee_lateral.n`` (paper Fig. 8): each femoral condyle, a sphere
  of radius ``rho_k`` about ``c_k`` (the circle fitted to the implant mesh,
  :func:`~ocp_constraints.biomech.knee_contact.implant_geometry`), touches its plateau plane
  (tray ``Y = h_k``, normal ``n_T = Q_T (-E1)``, pointing from the plateau to the femur):
  ``n_T . (v_Ck,femur - v_Ck,tibia) = 0``, position form ``n_T . (c_k - O_T) - rho_k -
  h_k``. Lagrange's prescription gives ``N_k n_T`` on the femur along the line through
  ``c_k`` and the contact point ``c_k - rho_k n_T`` (the load is reported at ``c_k``,
  on that line: the same force and moment about every point), and ``-N_k n_T`` on the
  tibia. ``N_k > 0`` is compression. About any point on the line through the two
  sphere centres (the flexion axis when the centres share their sagittal position) the
  pair is one force ``(N_medial + N_lateral) n_T`` plus a moment along
  ``E3 x n_T``, i.e. along ``g_2`` (``g_2`` is perpendicular to ``g_1 = E3`` and to
  ``g_3 = -n_T``): the paper's statement.
* ``knee.ap``, ``knee.ml``: the femoral origin O_F keeps its tray-frame ``X`` (``tx``)
  and ``Z`` (``tz``) coordinates (written at O_F, directions ``Q_T E2``, ``Q_T E3``).
* ``knee.ie``: ``g^3 . (omega_T - omega_F) = 0`` (no internal-external rotation), with
  ``g^3`` the dual Euler vector of the *relative* rotation ``Q_F^T Q_T`` decomposed into
  3-2-1 angles (:func:`relative_bases`; valid in any pose of the femur), position form
  the relative ``phi``.

The scene (``problems/knee.py``) adds gravity along ``+E1`` (the tibia hangs below the
held femur, swinging about the condyles) and an axial follower load ``axial_load`` at
the tray origin along ``n_T`` (pressing the plateau onto the condyles, as the muscles
and the body weight do in stance), so that both contact forces are compressive.
"""
from __future__ import annotations


import casadi as ca
import numpy as np

from .knee_contact import KNEE_COORDINATES, S, stored_geometry
from ..mechanics.model import Model
from ..mechanics.rotations import EulerSequence, elementary_rotation

CONTACT = ["knee_medial.n", "knee_lateral.n", "knee.ap", "knee.ml", "knee.ie"]
SIDES = ("medial", "lateral")
_SEQ = EulerSequence("321")


def default_parameters() -> dict[str, float]:
    """Scene and model parameters (SI units); implant geometry fitted from the workshop meshes."""
    return {"femur_mass": 0.6, "tibia_mass": 0.3, "com_height": 0.03, "gravity": 9.81, "axial_load": 50.0,
            "flexion0_deg": 20.0, "t_final": 1.0, "knee_tx": 0.0, "knee_tz": 0.0, "knee_ty": 0.042,
            **stored_geometry()}


def condyle_centre(p: dict[str, float], side: str) -> np.ndarray:
    """Sphere centre of a condyle in the knee basis, relative to the femoral origin (m)."""
    return S.T @ np.array([p[f"{side}_cx"], p[f"{side}_cy"], p[f"{side}_cz"]])


def tibia_rotation_from_jw(flexion, adduction, rotation):
    """``Q_T = R1(-rotation) R2(-adduction) R3(-flexion)``: the tibia relative to the femur, knee basis."""
    return elementary_rotation(1, -rotation) @ elementary_rotation(2, -adduction) @ elementary_rotation(3, -flexion)


def angles_321(Q):
    """3-2-1 angles ``(psi, theta, phi)`` of ``Q = R3(psi) R2(theta) R1(phi)`` (|theta| < pi/2)."""
    psi = ca.atan2(Q[1, 0], Q[0, 0])
    theta = ca.atan2(-Q[2, 0], ca.sqrt(Q[0, 0] ** 2 + Q[1, 0] ** 2))
    phi = ca.atan2(Q[2, 1], Q[2, 2])
    return ca.vertcat(psi, theta, phi)


def tibia_angles(p):
    """The paper's 3-2-1 angles of the tibia relative to the femur from JW knee coordinates ``p`` (6 or 3)."""
    return angles_321(tibia_rotation_from_jw(p[0], p[1], p[2]))


def knee_pose(p):
    """JW knee coordinates ``p = (flexion, adduction, rotation, tx, ty, tz)`` -> tibia angles, tray origin.

    Returns ``(psi, theta, phi)`` (the relative 3-2-1 angles) and ``O_T = -Q_T (-ty, tx, tz)``
    in the knee basis (femoral origin at the origin). Works on numbers or CasADi symbols.
    """
    Q = tibia_rotation_from_jw(p[0], p[1], p[2])
    return angles_321(Q), -Q @ ca.vertcat(-p[4], p[3], p[5])


def jw_coordinates(angles, origin) -> np.ndarray:
    """Inverse of :func:`knee_pose`: tibia 3-2-1 angles and tray origin -> JW knee coordinates."""
    Q = np.asarray(_SEQ.rotation(ca.DM(np.asarray(angles, float))))
    f, a, r = np.asarray(angles_321(ca.DM(Q.T)), float).ravel()    # S^T R_FM S = Q_T^T = R3(f) R2(a) R1(r)
    p_fm = S @ (-Q.T @ np.asarray(origin, float))       # S^T p_FM = -Q_T^T O_T
    return np.array([f, a, r, p_fm[0], p_fm[1], p_fm[2]])


def relative_bases(femur, tibia):
    """Relative 3-2-1 angles of the tibia w.r.t. the femur, their Euler and dual Euler bases (fixed basis).

    ``R = Q_F^T Q_T = R3(psi) R2(theta) R1(phi)``; ``omega_T - omega_F = sum rate_i g_i``
    with ``g_i = Q_F g_i(R)``; ``g^i`` likewise, so ``g^i . (omega_T - omega_F)`` is the
    i-th relative angle rate in any pose of the femur.
    """
    angles = angles_321(femur.Q.T @ tibia.Q)
    g = [femur.Q @ v for v in _SEQ.euler_basis(angles)]
    dual = [femur.Q @ v for v in _SEQ.dual_euler_basis(angles)]
    return angles, g, dual


def knee_model(p: dict[str, float]) -> Model:
    """The two-body knee (module docstring); ``p`` as :func:`default_parameters`."""
    model = Model("knee", gravity=(p["gravity"], 0.0, 0.0), parameters=p)
    J = np.diag([2e-3, 3e-3, 3e-3])
    femur = model.add_body("femur", p["femur_mass"], J, rotation="321")
    tibia = model.add_body("tibia", p["tibia_mass"], J, rotation="321")
    com_f = np.array([-p["com_height"], 0.0, 0.0])          # femur com above the femoral origin
    com_t = np.array([p["com_height"], 0.0, 0.0])           # tibia com below the tray origin
    OF = femur.point("O", -com_f)
    for k in range(3):                                        # the femur is held
        e = ca.DM(np.eye(3)[k])
        model.add_constraint(f"femur_fixed.v{k + 1}", ca.dot(e, OF.v), joint="femur_fixed",
                             position=ca.dot(e, OF.position), point=OF)
        model.add_constraint(f"femur_fixed.w{k + 1}", ca.dot(e, femur.omega), joint="femur_fixed",
                             position=femur.rotation_parameters[2 - k])
    OT = tibia.point("O", -com_t)
    QT = tibia.Q
    nT = QT @ ca.DM([-1.0, 0.0, 0.0])                        # plateau normal (tray +Y), towards the femur

    def tibia_velocity(x):   # velocity of the tibia's material point now at x (eq. 8)
        return tibia.vbar + ca.cross(tibia.omega, x - tibia.xbar)

    for side in SIDES:
        C = femur.point(f"C_{side}", condyle_centre(p, side) - com_f)
        model.add_constraint(f"knee_{side}.n", ca.dot(nT, C.v - tibia_velocity(C.position)), joint=f"knee_{side}",
                             position=ca.dot(nT, C.position - OT.position) - p[f"{side}_radius"] - p[f"{side}_height"],
                             point=C)
    rel = OF.v - tibia_velocity(OF.position)
    for k, tag, value in ((1, "ap", p["knee_tx"]), (2, "ml", p["knee_tz"])):
        e = QT @ ca.DM(np.eye(3)[k])
        model.add_constraint(f"knee.{tag}", ca.dot(e, rel), joint="knee", point=OF,
                             position=ca.dot(e, OF.position - OT.position) - value)
    angles, _, dual = relative_bases(femur, tibia)
    model.add_constraint("knee.ie", ca.dot(dual[2], tibia.omega - femur.omega), joint="knee", position=angles[2])
    if p.get("axial_load", 0.0):
        model.add_force("axial_load", OT, p["axial_load"] * nT)
    return model


def seated_pose(p: dict[str, float], psi: float, phi: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Tibia angles and tray origin with both condyles on their plateaus at flexion ``psi``.

    ``knee_tx``, ``knee_tz`` from ``p``; varus-valgus ``theta`` and ``ty`` solved (Newton).
    """
    c = [condyle_centre(p, s) for s in SIDES]
    off = [p[f"{s}_radius"] + p[f"{s}_height"] for s in SIDES]

    def residual(x):
        Q = np.asarray(_SEQ.rotation(ca.DM([psi, x[0], phi])))
        O = -Q @ np.array([-x[1], p["knee_tx"], p["knee_tz"]])
        n = -Q[:, 0]
        return np.array([n @ (ck - O) - o for ck, o in zip(c, off)]), O

    x = np.array([0.0, p["knee_ty"]])
    for _ in range(50):
        r, _ = residual(x)
        if np.abs(r).max() < 1e-15:
            break
        J = np.column_stack([(residual(x + d)[0] - r) / 1e-7 for d in np.eye(2) * 1e-7])
        x = x - np.linalg.solve(J, r)
    return np.array([psi, x[0], phi]), residual(x)[1]


def coordinates(p: dict[str, float], angles, origin) -> dict[str, float]:
    """Scene coordinates (femur held at the identity, tibia at ``angles``, tray origin ``origin``)."""
    Q = np.asarray(_SEQ.rotation(ca.DM(np.asarray(angles, float))))
    xt = np.asarray(origin, float) + Q @ np.array([p["com_height"], 0.0, 0.0])
    out = {"femur.x": -p["com_height"], "femur.y": 0.0, "femur.z": 0.0, "femur.psi": 0.0, "femur.theta": 0.0,
           "femur.phi": 0.0}
    out.update({"tibia.x": xt[0], "tibia.y": xt[1], "tibia.z": xt[2], "tibia.psi": float(angles[0]),
                "tibia.theta": float(angles[1]), "tibia.phi": float(angles[2])})
    return out


def coordinates_from_jw(p: dict[str, float], q6) -> ca.SX | np.ndarray:
    """Scene coordinate vector (model order: femur, tibia) from JW knee coordinates (numbers or SX)."""
    ang, origin = knee_pose(q6)
    Q = _SEQ.rotation(ang)
    xt = origin + Q @ ca.DM([p["com_height"], 0.0, 0.0])
    q_f = ca.DM([-p["com_height"], 0, 0, 0, 0, 0])
    return ca.vertcat(q_f, xt, ang)


def contact_matrix_function(params: dict[str, float] | None = None) -> ca.Function:
    """``p (JW knee coordinates) -> A`` (5 x 6): ``Phi_p = lambda A`` of the knee constraints (eq. 39).

    ``A = G B dq/dp`` with ``q(p)`` from :func:`coordinates_from_jw` (femur held). The
    generalized forces of internal loads depend only on the relative motion, so ``A`` is
    that of the JW model's knee coordinates whichever body is held.
    """
    from ..mechanics.equations import SystemEquations

    p = default_parameters() if params is None else dict(params)
    model = knee_model({**p, "axial_load": 0.0})
    eqs = SystemEquations(model)
    P = ca.SX.sym("p", 6)
    q = coordinates_from_jw(p, P)
    G = eqs.constraint_functions(q, ca.DM.zeros(eqs.nu), 0.0, ca.DM.zeros(eqs.inputs.numel()))[0]
    A = G @ eqs.speeds_from_rates(q) @ ca.jacobian(q, P)
    rows = [eqs.constraint_names.index(c) for c in CONTACT]
    return ca.Function("knee_A", [P], [A[rows, :]], ["p"], ["A"])


__all__ = ["CONTACT", "KNEE_COORDINATES", "angles_321", "contact_matrix_function", "coordinates",
           "coordinates_from_jw", "default_parameters", "jw_coordinates", "knee_model", "knee_pose",
           "seated_pose", "tibia_angles"]
