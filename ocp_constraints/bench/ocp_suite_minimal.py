"""The user-problem suite in minimal coordinates: the independent formulation of each problem.

Each problem's equations of motion are derived here from its kinetic and potential energy in
the fewest coordinates (Lagrange's equations, or Maggi's equations for the rolling disk's
non-holonomic contact), with plain CasADi and none of the library: no bodies, no constraint
multipliers. Loads the problems bound (a four-bar's pin force, contact forces under a friction
cone) come from Newton-Euler balances of the bodies concerned, written out per problem.
The result is a semi-explicit DAE ``x' = f(x, z, u)``, ``0 = g(x, z, u)`` with ``x = (q, s)`` and
the accelerations ``s'`` (and any loads) as algebraic variables ``z``, so no mass matrix is
inverted symbolically; with an integrand, bounds and boundary values it is what
:mod:`.ocp_suite_peers` hands to rockit and to its own collocation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from . import ocp_suite_params as P

G = P.G


@dataclass
class Minimal:
    """``min int cost dt`` s.t. ``x' = xdot``, ``alg = 0`` (of ``x, z, u``), bounds, path constraints,
    boundary values of ``x`` (None: free)."""

    name: str
    x: ca.SX
    z: ca.SX
    u: ca.SX
    xdot: ca.SX
    alg: ca.SX
    cost: ca.SX
    T: float
    x0: list
    xf: list
    u_bounds: list
    x_bounds: dict = field(default_factory=dict)      # state index -> (lower, upper)
    path: list = field(default_factory=list)          # (expression of x, z, u; lower; upper)
    description: str = ""
    guesses: dict = field(default_factory=dict)       # state index -> function of time (CasADi operations)

    def guess(self, tau) -> np.ndarray:
        """States at fractions ``tau`` of the horizon: the guessed ones from :attr:`guesses`, the others
        linear between their boundary values (0 where free at both ends)."""
        tau = np.atleast_1d(np.asarray(tau, float))
        a = np.array([v if v is not None else (w if w is not None else 0.0) for v, w in zip(self.x0, self.xf)])
        b = np.array([w if w is not None else start for w, start in zip(self.xf, a)])
        out = a[:, None] + (b - a)[:, None] * tau[None, :]
        for i, fn in self.guesses.items():
            out[i] = np.asarray(ca.DM(fn(ca.DM(tau * self.T)))).ravel()
        return out


@dataclass
class Dynamics:
    """Lagrange's (or Maggi's) equations as ``x' = xdot``, ``alg = 0`` with algebraic ``z = s'``;
    ``qdd`` is ``q''`` in terms of ``q, s, z`` (for accelerations of points)."""

    x: ca.SX
    z: ca.SX
    xdot: ca.SX
    alg: ca.SX
    qdd: ca.SX
    qd: ca.SX


def lagrange(q, qd, T, V, power, S=None, s=None) -> Dynamics:
    """``d/dt dL/dq' - dL/dq = Q``, ``L = T - V``, ``Q = d(power)/d(q')``: ``M q'' = b``.

    ``power`` is the applied loads' power (linear in ``q'``). With ``S``, ``s`` the motion is
    restricted to ``q' = S(q) s`` (non-holonomic; Maggi's equations ``S^T (M q'' - b) = 0`` with
    ``q'' = S s' + (d(S s)/dq) S s``). The state is ``(q, q')`` or ``(q, s)``.
    """
    L = T - V
    p = ca.gradient(L, qd)
    M = ca.jacobian(p, qd)
    b = ca.gradient(power, qd) + ca.gradient(L, q) - ca.jacobian(p, q) @ qd
    if S is None:
        a = ca.SX.sym("qdd", q.numel())
        return Dynamics(ca.vertcat(q, qd), a, ca.vertcat(qd, a), M @ a - b, a, qd)
    sd = ca.SX.sym("sd", s.numel())
    v = S @ s
    qdd = S @ sd + ca.jacobian(v, q) @ v
    alg = ca.substitute(S.T @ (M @ qdd - b), qd, v)
    return Dynamics(ca.vertcat(q, s), sd, ca.vertcat(v, sd), alg, qdd, v)


def acceleration(position, q, dyn: Dynamics) -> ca.SX:
    """Second time derivative of ``position(q)``: ``J q'' + (d(J q')/dq) q'`` in the state's terms."""
    qd = ca.SX.sym("qd", q.numel())
    J = ca.jacobian(position, q)
    return J @ dyn.qdd + ca.substitute(ca.jacobian(J @ qd, q) @ qd, qd, dyn.qd)


def _minimal(name, dyn: Dynamics, u, cost, T, x0, xf, u_bounds, z=None, alg=None, **kw) -> Minimal:
    """The problem of ``dyn`` with more algebraic variables ``z`` (and their equations ``alg``) if given."""
    z_all = dyn.z if z is None else ca.vertcat(dyn.z, z)
    alg_all = dyn.alg if alg is None else ca.vertcat(dyn.alg, alg)
    return Minimal(name, dyn.x, z_all, u, dyn.xdot, alg_all, cost, T, x0, xf, u_bounds, **kw)


def _rod(m, l, a, b):
    """Kinetic energy of a uniform rod of mass m, length l, center velocity a, angular rate b."""
    return 0.5 * m * ca.dot(a, a) + 0.5 * m * l**2 / 12 * b**2


def _u(angle) -> ca.SX:
    """Unit vector (sin, -cos) of a rod hanging at ``angle`` from -E2, counterclockwise."""
    return ca.vertcat(ca.sin(angle), -ca.cos(angle))


# -- planar problems --------------------------------------------------------------------------------
def acrobot() -> Minimal:
    """Absolute angles ``q1, q2`` of the two rods from hanging down; motor torque at the elbow."""
    p = P.ACROBOT
    q, qd, tau = ca.SX.sym("q", 2), ca.SX.sym("qd", 2), ca.SX.sym("tau")
    c1 = p["l1"] / 2 * _u(q[0])
    elbow = p["l1"] * _u(q[0])
    c2 = elbow + p["l2"] / 2 * _u(q[1])
    v1, v2 = (ca.jacobian(c, q) @ qd for c in (c1, c2))
    T = _rod(p["m1"], p["l1"], v1, qd[0]) + _rod(p["m2"], p["l2"], v2, qd[1])
    V = G * (p["m1"] * c1[1] + p["m2"] * c2[1])
    dyn = lagrange(q, qd, T, V, tau * (qd[1] - qd[0]))
    x0, xf = [0.0, 0.0, 0.0, 0.0], [math.pi, math.pi, 0.0, 0.0]
    return _minimal("acrobot", dyn, tau, tau**2, p["T"], x0, xf, [(-p["tau_max"], p["tau_max"])],
                    description="2 angles")


def cart_double_pendulum() -> Minimal:
    """Cart position ``x`` and the rods' absolute angles ``q1, q2`` from hanging down; push on the cart."""
    p = P.CART_DOUBLE
    q, qd, f = ca.SX.sym("q", 3), ca.SX.sym("qd", 3), ca.SX.sym("f")
    cart = ca.vertcat(q[0], 0)
    c1 = cart + p["l1"] / 2 * _u(q[1])
    c2 = cart + p["l1"] * _u(q[1]) + p["l2"] / 2 * _u(q[2])
    v1, v2 = (ca.jacobian(c, q) @ qd for c in (c1, c2))
    T = 0.5 * p["m0"] * qd[0] ** 2 + _rod(p["m1"], p["l1"], v1, qd[1]) + _rod(p["m2"], p["l2"], v2, qd[2])
    V = G * (p["m1"] * c1[1] + p["m2"] * c2[1])
    dyn = lagrange(q, qd, T, V, f * qd[0])
    x0, xf = [0.0] * 6, [0.0, math.pi, math.pi, 0.0, 0.0, 0.0]
    return _minimal("cart_double_pendulum", dyn, f, f**2, p["T"], x0, xf, [(-p["f_max"], p["f_max"])],
                    x_bounds={0: (-p["x_max"], p["x_max"])}, description="3 coordinates")


def _cross2(r, f):
    return r[0] * f[1] - r[1] * f[0]


def four_bar_geometry(theta):
    """Points A, B and the coupler and rocker angles of the four-bar (closed form, elbow-up branch)."""
    p = P.FOUR_BAR
    A = p["a"] * ca.vertcat(ca.cos(theta), ca.sin(theta))
    D = ca.vertcat(p["d"], 0)
    r = D - A
    rho = ca.norm_2(r)
    e = r / rho
    n = ca.vertcat(-e[1], e[0])
    along = (p["b"] ** 2 - p["c"] ** 2 + rho**2) / (2 * rho)
    B = A + along * e + ca.sqrt(p["b"] ** 2 - along**2) * n
    return A, B, D, ca.atan2(B[1] - A[1], B[0] - A[0]), ca.atan2(B[1] - D[1], B[0] - D[0])


def four_bar() -> Minimal:
    """The crank angle ``theta`` alone (one degree of freedom); the pin force at B from Newton-Euler
    on the coupler and the rocker (four equations for the pin forces at A and B)."""
    p = P.FOUR_BAR
    th, thd, tau = ca.SX.sym("theta"), ca.SX.sym("theta_dot"), ca.SX.sym("tau")
    A, B, D, beta, gamma = four_bar_geometry(th)
    ma, mb, mc = (p["rho"] * p[k] for k in "abc")
    cc, cr = (A + B) / 2, (D + B) / 2           # coupler and rocker centers
    betad, gammad = ca.jacobian(beta, th) * thd, ca.jacobian(gamma, th) * thd
    T = 0.5 * (ma * p["a"] ** 2 / 3) * thd**2 + _rod(mb, p["b"], ca.jacobian(cc, th) * thd, betad) \
        + 0.5 * (mc * p["c"] ** 2 / 3) * gammad**2
    V = G * (ma * A[1] / 2 + mb * cc[1] + mc * cr[1])
    dyn = lagrange(th, thd, T, V, tau * thd)
    # Newton-Euler: coupler m a_c = F_A + F_B - m g E2, I alpha_c = (A - c) x F_A + (B - c) x F_B;
    # rocker about D: I_D alpha_r = (B - D) x (-F_B) - (c_r - D) x m_r g E2. Unknowns F_A, F_B
    # (forces on the coupler), algebraic variables with these four equations.
    ac = acceleration(cc, th, dyn)
    alpha_c, alpha_r = (acceleration(a, th, dyn) for a in (beta, gamma))
    F = ca.SX.sym("F", 4)
    FA, FB = F[0:2], F[2:4]
    grav = ca.vertcat(0, -G)
    eqs = ca.vertcat(mb * ac - FA - FB - mb * grav,
                     mb * p["b"] ** 2 / 12 * alpha_c - _cross2(A - cc, FA) - _cross2(B - cc, FB),
                     mc * p["c"] ** 2 / 3 * alpha_r + _cross2(B - D, FB) - _cross2(cr - D, mc * grav))
    x0, xf = [0.0, 0.0], [2 * math.pi, 0.0]
    return _minimal("four_bar", dyn, tau, tau**2, p["T"], x0, xf, [(-ca.inf, ca.inf)], z=F, alg=eqs,
                    path=[(ca.sumsqr(FB), -ca.inf, p["f_pin_max"] ** 2)], description="1 angle")
