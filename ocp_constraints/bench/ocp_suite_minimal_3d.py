"""Minimal-coordinate formulations of the suite's rolling disk, quadrotor with a load, and walker.

As in :mod:`.ocp_suite_minimal`: energies in the fewest coordinates, Lagrange's (or Maggi's)
equations by CasADi differentiation, and the contact forces the problems bound from the
balance of linear momentum of the bodies concerned. None of the library is used.
"""
from __future__ import annotations

import math

import casadi as ca

from . import ocp_suite_params as P
from .ocp_suite_minimal import Minimal, _minimal, acceleration, lagrange

G = P.G


def _R1(a):
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, ca.cos(a), -ca.sin(a)), ca.horzcat(0, ca.sin(a), ca.cos(a)))


def _R2(a):
    return ca.vertcat(ca.horzcat(ca.cos(a), 0, ca.sin(a)), ca.horzcat(0, 1, 0), ca.horzcat(-ca.sin(a), 0, ca.cos(a)))


def _R3(a):
    return ca.vertcat(ca.horzcat(ca.cos(a), -ca.sin(a), 0), ca.horzcat(ca.sin(a), ca.cos(a), 0), ca.horzcat(0, 0, 1))


def _omega_fixed(R, q, qd) -> ca.SX:
    """Angular velocity in the fixed basis from ``skew(omega) = R' R^T``."""
    Rd = sum((ca.jacobian(ca.vec(R), q[i]) * qd[i] for i in range(q.numel())), ca.SX.zeros(9, 1))
    W = ca.reshape(Rd, 3, 3) @ R.T
    return ca.vertcat(W[2, 1], W[0, 2], W[1, 0])


# -- rolling disk ---------------------------------------------------------------------------------
def rolling_disk() -> Minimal:
    """Center ``(x, y)`` and 3-1-3 angles ``(psi, theta, phi)`` (the center's height ``R sin(theta)``
    eliminated), speeds ``s = (psi', theta', phi')``; rolling gives ``(x', y')`` from ``s``.
    Contact force ``F = m a_G - m g`` (balance of linear momentum; the torques act on the disk alone)."""
    p = P.DISK
    m, R = p["m"], p["R"]
    q, qd, s, tau = ca.SX.sym("q", 5), ca.SX.sym("qd", 5), ca.SX.sym("s", 3), ca.SX.sym("tau", 3)
    psi, theta, phi = q[2], q[3], q[4]
    Q = _R3(psi) @ _R1(theta) @ _R3(phi)
    up = _R3(psi) @ _R1(theta) @ ca.DM([0, 1, 0])          # from the contact point to the center
    G_pos = ca.vertcat(q[0], q[1], R * ca.sin(theta))
    vG = ca.jacobian(G_pos, q) @ qd
    w = _omega_fixed(Q, q, qd)
    J = Q @ ca.diag(ca.DM([m * R**2 / 4, m * R**2 / 4, m * R**2 / 2])) @ Q.T
    T = 0.5 * m * ca.dot(vG, vG) + 0.5 * ca.dot(w, J @ w)
    V = m * G * R * ca.sin(theta)
    # Rolling: v_G = omega x (R up) for the angle rates s; so q' = S(q) s.
    Wang = ca.jacobian(w, qd[2:5])                        # omega = Wang (psi', theta', phi')
    vroll = ca.cross(Wang @ s, R * up)
    S = ca.vertcat(ca.jacobian(vroll[0:2], s), ca.SX.eye(3))
    dyn = lagrange(q, qd, T, V, ca.dot(tau, w), S, s)
    F = m * acceleration(G_pos, q, dyn) + m * G * ca.DM([0, 0, 1])
    rest = [0.0, 0.0, 0.0]
    x0 = [0.0, 0.0, 0.0, math.pi / 2, 0.0] + rest
    xf = [p["x"], p["y"], p["psi"], math.pi / 2, None] + rest
    cone = ca.sumsqr(F[0:2]) - p["mu"] ** 2 * F[2] ** 2
    return _minimal("rolling_disk", dyn, tau, ca.sumsqr(tau), p["T"], x0, xf, [(-ca.inf, ca.inf)] * 3,
                    path=[(F[2], 0.0, ca.inf), (cone, -ca.inf, 0.0)], description="5 coordinates, 3 speeds")


# -- quadrotor with a hanging load -------------------------------------------------------------
def quadrotor_load() -> Minimal:
    """Quadrotor position and 3-2-1 angles (yaw, pitch, roll), the load's direction by two angles
    ``(a, b)``: ``r = L R2(b) R1(a) (0, 0, -1)`` from the hook; thrusts ``f_k`` along the rotor axis."""
    p = P.QUAD
    q, qd, f = ca.SX.sym("q", 8), ca.SX.sym("qd", 8), ca.SX.sym("f", 4)
    R = _R3(q[3]) @ _R2(q[4]) @ _R1(q[5])
    x = q[0:3]
    hook = x + R @ ca.DM([0, 0, -p["hook"]])
    load = hook + p["L"] * (_R2(q[7]) @ _R1(q[6]) @ ca.DM([0, 0, -1]))
    w = _omega_fixed(R, q, qd)
    wb = R.T @ w
    vq, vl = ca.jacobian(x, q) @ qd, ca.jacobian(load, q) @ qd
    T = 0.5 * p["M"] * ca.dot(vq, vq) + 0.5 * ca.dot(wb, ca.DM([p["Ixx"], p["Iyy"], p["Izz"]]) * wb) \
        + 0.5 * p["m_load"] * ca.dot(vl, vl)
    V = G * (p["M"] * x[2] + p["m_load"] * load[2])
    a = p["arm"]
    rotors = [ca.DM([a, 0, 0]), ca.DM([0, a, 0]), ca.DM([-a, 0, 0]), ca.DM([0, -a, 0])]
    power = 0
    for k, r in enumerate(rotors):
        power += ca.dot(f[k] * R[:, 2], ca.jacobian(x + R @ r, q) @ qd)
    power += p["k"] * (f[0] - f[1] + f[2] - f[3]) * ca.dot(R[:, 2], w)
    dyn = lagrange(q, qd, T, V, power)
    x0 = [0.0] * 16
    xf = [p["x"], p["y"], p["z"]] + [0.0] * 13
    return _minimal("quadrotor_load", dyn, f, ca.sumsqr(f), p["T"], x0, xf, [(0.0, p["f_max"])] * 4,
                    description="8 coordinates")


# -- planar five-link walker ----------------------------------------------------------------------
LINKS = ("stance_shank", "stance_thigh", "torso", "swing_thigh", "swing_shank")


def walker_chain(q):
    """Points of the walker from the lean angles ``q`` (upper end towards +E1): stance foot at the
    origin, knee, hip, head, swing knee, swing foot; and the five link centers."""
    p = P.WALKER
    up = lambda a: ca.vertcat(ca.sin(a), ca.cos(a))
    foot = ca.DM.zeros(2)
    knee = foot + p["l_shank"] * up(q[0])
    hip = knee + p["l_thigh"] * up(q[1])
    head = hip + p["l_torso"] * up(q[2])
    knee2 = hip - p["l_thigh"] * up(q[3])
    foot2 = knee2 - p["l_shank"] * up(q[4])
    centers = [(foot + knee) / 2, (knee + hip) / 2, (hip + head) / 2, (hip + knee2) / 2, (knee2 + foot2) / 2]
    return foot2, centers


def walker_ends() -> tuple[list, list]:
    """Lean angles of the five links at the start and at the end of the step."""
    p = P.WALKER
    stance = [p["stance_shank"], p["stance_thigh"], p["torso"]]
    a, b = p["swing_thigh"], p["swing_shank"]
    return stance + [a, b], stance + [-b, -a]


def walker() -> Minimal:
    """Five lean angles (stance foot pinned at the origin); an ankle torque on the stance shank, hip
    torques between the torso and each thigh, knee torques between thigh and shank. Stance contact
    force ``F = sum m_i (a_i - g)`` (balance of linear momentum of the five links)."""
    p = P.WALKER
    q, qd, tau = ca.SX.sym("q", 5), ca.SX.sym("qd", 5), ca.SX.sym("tau", 5)
    masses = [p["m_shank"], p["m_thigh"], p["m_torso"], p["m_thigh"], p["m_shank"]]
    lengths = [p["l_shank"], p["l_thigh"], p["l_torso"], p["l_thigh"], p["l_shank"]]
    foot2, centers = walker_chain(q)
    T, V = 0, 0
    for m, l, c, rate in zip(masses, lengths, centers, ca.vertsplit(qd)):
        v = ca.jacobian(c, q) @ qd
        T += 0.5 * m * ca.dot(v, v) + 0.5 * m * l**2 / 12 * rate**2
        V += m * G * c[1]
    # Lean angles turn clockwise, so a counterclockwise torque tau on link i does work -tau q_i'.
    ankle, hip1, hip2, knee1, knee2 = ca.vertsplit(tau)
    power = -(ankle * qd[0] + hip1 * (qd[1] - qd[2]) + hip2 * (qd[3] - qd[2]) + knee1 * (qd[0] - qd[1])
              + knee2 * (qd[4] - qd[3]))
    dyn = lagrange(q, qd, T, V, power)
    F = sum((m * (acceleration(c, q, dyn) + ca.DM([0, G])) for m, c in zip(masses, centers)), ca.SX.zeros(2))
    start, end = walker_ends()
    mu, foot = p["mu"], p["foot"]
    path = [(F[1], 0.0, ca.inf), (F[0] - mu * F[1], -ca.inf, 0.0), (F[0] + mu * F[1], 0.0, ca.inf),
            (ankle - foot * F[1], -ca.inf, 0.0), (ankle + foot * F[1], 0.0, ca.inf),
            (foot2[1], 0.0, ca.inf), (q[0] - q[1], 0.0, ca.inf), (q[4] - q[3], 0.0, ca.inf)]
    return _minimal("walker", dyn, tau, ca.sumsqr(tau), p["T"], start + [0.0] * 5, end + [0.0] * 5,
                    [(-ca.inf, ca.inf)] * 5, path=path, description="5 angles")
