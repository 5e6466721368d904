"""Four textbook optimal-control problems through the public API of ocp_constraints, each with an
independent closed-form reference (Pontryagin / KKT), evaluated exactly (piecewise polynomials,
integrated symbolically with numpy.polynomial; trig of the exact angle for the rod).

Problems
  P1 clipped_push : block (prismatic joint, zero gravity), rest-to-rest D in fixed T, min int F^2, |F| <= Fmax.
  P2 speed_limit  : same block, min int F^2, v <= Vmax reached on a middle arc.
  P3 rod_torque   : rod on a revolute joint (zero gravity), rest-to-rest angle Theta in T, min int tau^2, |tau| <= tmax.
  P4 min_time     : block, min T, F in [-Fdn, Fup] (asymmetric), rest-to-rest D, free final time.

In P1/P2/P4 the push acts at a body point offset by h along body E2 from the centre of mass, so the
prismatic joint's moment multiplier rail.w3 = h F(t) is a non-trivial constraint load (all other
multipliers are 0 in zero gravity).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import Polynomial as Poly

# ----------------------------------------------------------------------------------------------
# parameters (chosen here, not taken from the library's tests)
P1 = dict(m=1.5, D=0.8, T=1.2, Fmax=4.0, h=0.1)
P2 = dict(m=1.2, D=1.0, T=2.0, Vmax=0.6, h=0.1)
P3 = dict(m=0.8, L=0.6, Theta=1.2, T=0.8, tmax=0.9)
P4 = dict(m=1.5, D=2.0, Fup=3.0, Fdn=6.0, h=0.1)


# ----------------------------------------------------------------------------------------------
class PiecewiseMotion:
    """Acceleration as polynomials (in absolute t) on pieces; velocity and position integrated exactly
    with continuity and zero initial position/velocity."""

    def __init__(self, breaks, acc_polys, x0=0.0, v0=0.0):
        self.breaks = np.asarray(breaks, float)
        self.acc = list(acc_polys)
        self.vel, self.pos = [], []
        v_start, x_start = v0, x0
        for k, a in enumerate(self.acc):
            t0 = self.breaks[k]
            v = a.integ(lbnd=t0, k=v_start)          # v(t0) = v_start
            x = v.integ(lbnd=t0, k=x_start)
            self.vel.append(v)
            self.pos.append(x)
            t1 = self.breaks[k + 1]
            v_start, x_start = v(t1), x(t1)
        self.v_end, self.x_end = v_start, x_start

    def _eval(self, polys, t):
        t = np.asarray(t, float)
        idx = np.clip(np.searchsorted(self.breaks, t, side="right") - 1, 0, len(polys) - 1)
        out = np.empty_like(t)
        for k, p in enumerate(polys):
            sel = idx == k
            out[sel] = p(t[sel])
        return out

    def a(self, t):
        return self._eval(self.acc, t)

    def v(self, t):
        return self._eval(self.vel, t)

    def x(self, t):
        return self._eval(self.pos, t)

    def effort(self, scale):
        """int (scale * a)^2 dt exactly."""
        s = 0.0
        for k, a in enumerate(self.acc):
            q = (a * scale) ** 2
            Q = q.integ()
            s += Q(self.breaks[k + 1]) - Q(self.breaks[k])
        return s


def clipped_linear_reference(mass, dist, T, umax):
    """Rest-to-rest 'dist' in T for mass*acc = u, min int u^2, |u| <= umax.

    Pontryagin: H = u^2 + p1 v + p2 u / mass, p1 const, p2 linear, u = clip(-p2 / (2 mass)) = clip(a + b t).
    The problem is symmetric under t -> T - t, u -> -u (and convex, so the optimum is unique), hence
    u(t) = clip(k (T/2 - t), -umax, umax). With s = T/2 - t, x(T) = (1/mass) int_0^T (T - t) u dt and
    int u = 0, so mass*dist = int_{-T/2}^{T/2} s clip(k s) ds = 2[k s_c^3/3 + umax (T^2/8 - s_c^2/2)]
    = umax (T^2/4 - s_c^2/3), with s_c = umax/k the half-width of the unsaturated middle part:
        s_c = sqrt(3 (T^2/4 - mass*dist/umax)),   k = umax / s_c.
    Valid (saturating) iff  T^2/6 < mass*dist/umax < T^2/4.
    """
    md = mass * dist / umax
    assert T**2 / 6 < md < T**2 / 4, "bound would not saturate or problem infeasible"
    sc = math.sqrt(3 * (T**2 / 4 - md))
    k = umax / sc
    t1, t2 = T / 2 - sc, T / 2 + sc
    acc = [Poly([umax / mass]), Poly([k * T / 2 / mass, -k / mass]), Poly([-umax / mass])]
    mot = PiecewiseMotion([0.0, t1, t2, T], acc)
    assert abs(mot.x_end - dist) < 1e-12 and abs(mot.v_end) < 1e-12, (mot.x_end, mot.v_end)
    return mot, dict(s_c=sc, k=k, t_sat_end=t1, t_sat_start=t2, objective=mot.effort(mass))


def speed_limit_reference(mass, dist, T, vmax):
    """Rest-to-rest 'dist' in T, min int F^2, v <= vmax (no force bound).

    Convex problem; KKT (first-order state constraint, u continuous at junctions): F = c (t1 - t) on
    [0, t1], F = 0 on the arc [t1, T - t1] where v = vmax, F = -c (t - (T - t1)) after. v(t1) = c t1^2 / (2 m)
    = vmax; x(t1) = 2 vmax t1 / 3; dist = 2 (2 vmax t1 / 3) + vmax (T - 2 t1) gives
        t1 = 3 (T - dist / vmax) / 2,  c = 2 m vmax / t1^2.
    Multiplier check: -2 m^2 v'' + nu + mu = 0 with nu = -4 m^2 vmax / t1^2 on the free arcs and
    mu = 4 m^2 vmax / t1^2 >= 0 on the bound arc, no atoms (v' continuous): KKT holds, so optimal.
    Valid iff 2T/3 < dist/vmax < T (the unconstrained peak speed 1.5 dist/T exceeds vmax).
    """
    assert 2 * T / 3 < dist / vmax < T
    t1 = 1.5 * (T - dist / vmax)
    c = 2 * mass * vmax / t1**2
    acc = [Poly([c * t1 / mass, -c / mass]), Poly([0.0]), Poly([c * (T - t1) / mass, -c / mass])]
    mot = PiecewiseMotion([0.0, t1, T - t1, T], acc)
    assert abs(mot.x_end - dist) < 1e-12 and abs(mot.v_end) < 1e-12, (mot.x_end, mot.v_end)
    assert abs(mot.v(np.array([t1]))[0] - vmax) < 1e-13
    return mot, dict(t1=t1, c=c, objective=mot.effort(mass))


def min_time_reference(mass, dist, fup, fdn):
    """Minimum time rest-to-rest 'dist', -fdn <= F <= fup: bang-bang, one switch (full push, then full brake).
    v(ts) = fup ts / m = fdn (T - ts) / m; dist = fup ts^2 / (2 m) (1 + fup / fdn):
        ts = sqrt(2 m dist / (fup (1 + fup / fdn))),  T = ts (1 + fup / fdn)."""
    ts = math.sqrt(2 * mass * dist / (fup * (1 + fup / fdn)))
    T = ts * (1 + fup / fdn)
    acc = [Poly([fup / mass]), Poly([-fdn / mass])]
    mot = PiecewiseMotion([0.0, ts, T], acc)
    assert abs(mot.x_end - dist) < 1e-12 and abs(mot.v_end) < 1e-12
    return mot, dict(ts=ts, T=T)


# ----------------------------------------------------------------------------------------------
# models through the public API

def block_model(p, name):
    import casadi as ca
    import ocp_constraints as oc

    model = oc.Model(name, gravity=(0.0, 0.0, 0.0))
    b = model.add_body("block", p["m"], np.diag([0.01, 0.01, 0.01]), rotation="321")
    oc.joints.prismatic(model, "rail", b.com, axis=(1, 0, 0))
    F = model.add_input("F")
    model.add_force("push", b.point("P", (0.0, p["h"], 0.0)), ca.vertcat(F, 0, 0))
    return model


def rod_problem(name, m, L, g, T, Theta):
    """A rod (mass m, length L) on a revolute joint at its end A about E3, gravity g along -E2, driven by a torque
    ``motor``; rest to rest from psi = 0 to Theta in T, least int tau^2 (the second newcomer's pendulums too)."""
    import casadi as ca
    import ocp_constraints as oc

    model = oc.Model(name, gravity=(0.0, -g, 0.0))
    rod = model.add_body("rod", m, m * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, L / 2, 0.0]), axis=(0, 0, 1))
    tau = model.add_input("motor")
    model.add_torque("motor", rod, ca.vertcat(0, 0, tau))
    ocp = oc.OptimalControlProblem(model, t_final=T)
    ocp.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    ocp.final({"rod.psi": Theta, "rod.psi_dot": 0.0})
    ocp.minimize_effort(["motor"])
    return ocp


def build(problem):
    import ocp_constraints as oc

    if problem == "clipped_push":
        p = P1
        ocp = oc.OptimalControlProblem(block_model(p, "clipped_push"), t_final=p["T"])
        ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
        ocp.final({"block.x": p["D"], "block.vbar_x": 0.0})
        ocp.bound("F", -p["Fmax"], p["Fmax"])
        ocp.minimize_effort(["F"])
        return ocp
    if problem == "speed_limit":
        p = P2
        ocp = oc.OptimalControlProblem(block_model(p, "speed_limit"), t_final=p["T"])
        ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
        ocp.final({"block.x": p["D"], "block.vbar_x": 0.0})
        ocp.bound("block.vbar_x", -10.0, p["Vmax"])
        ocp.minimize_effort(["F"])
        return ocp
    if problem == "rod_torque":
        p = P3
        ocp = rod_problem("rod_torque", p["m"], p["L"], 0.0, p["T"], p["Theta"])
        ocp.bound("motor", -p["tmax"], p["tmax"])
        return ocp
    if problem == "min_time":
        p = P4
        ocp = oc.OptimalControlProblem(block_model(p, "min_time"), t_final=2.0, t_final_bounds=(0.5, 5.0))
        ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
        ocp.final({"block.x": p["D"], "block.vbar_x": 0.0})
        ocp.bound("F", -p["Fdn"], p["Fup"])
        ocp.minimize_final_time()
        return ocp
    raise ValueError(problem)


# ----------------------------------------------------------------------------------------------
# references as functions of time: states dict, inputs dict, multipliers dict (sample names)

BLOCK_ZERO_STATES = ["block.y", "block.z", "block.psi", "block.theta", "block.phi", "block.vbar_y", "block.vbar_z",
                     "block.omega_x", "block.omega_y", "block.omega_z"]
BLOCK_ZERO_LAMBDAS = ["rail.n1.lambda", "rail.n2.lambda", "rail.w1.lambda", "rail.w2.lambda"]


def reference(problem):
    """Returns (T_ref, info, f) with f(t) -> (states, inputs, multipliers), each a dict name -> array."""
    if problem in ("clipped_push", "speed_limit", "min_time"):
        if problem == "clipped_push":
            p = P1
            mot, info = clipped_linear_reference(p["m"], p["D"], p["T"], p["Fmax"])
            T = p["T"]
        elif problem == "speed_limit":
            p = P2
            mot, info = speed_limit_reference(p["m"], p["D"], p["T"], p["Vmax"])
            T = p["T"]
        else:
            p = P4
            mot, info = min_time_reference(p["m"], p["D"], p["Fup"], p["Fdn"])
            T = info["T"]

        def f(t):
            t = np.asarray(t, float)
            z = np.zeros_like(t)
            F = p["m"] * mot.a(t)
            states = {"block.x": mot.x(t), "block.vbar_x": mot.v(t)}
            states.update({n: z for n in BLOCK_ZERO_STATES})
            lambdas = {"rail.w3.lambda": p["h"] * F}
            lambdas.update({n: z for n in BLOCK_ZERO_LAMBDAS})
            return states, {"F": F}, lambdas

        return T, info, f
    if problem == "rod_torque":
        p = P3
        m, L = p["m"], p["L"]
        J = m * L**2 / 3
        mot, info = clipped_linear_reference(J, p["Theta"], p["T"], p["tmax"])
        r = L / 2

        def f(t):
            t = np.asarray(t, float)
            th, w, al = mot.x(t), mot.v(t), mot.a(t)
            s, c = np.sin(th), np.cos(th)
            z = np.zeros_like(t)
            # centre of mass at (r sin th, -r cos th) for the hinge at the origin, rod hanging at th = 0
            states = {"rod.psi": th, "rod.psi_dot": w, "rod.omega_z": w,
                      "rod.x": r * s, "rod.y": -r * c, "rod.vbar_x": r * w * c, "rod.vbar_y": r * w * s}
            states.update({n: z for n in ("rod.z", "rod.theta", "rod.phi", "rod.theta_dot", "rod.phi_dot",
                                          "rod.vbar_z", "rod.omega_x", "rod.omega_y")})
            # zero gravity: hinge force on the rod = m a_com
            Fx = m * (r * al * c - r * w**2 * s)
            Fy = m * (r * al * s + r * w**2 * c)
            # multipliers: hinge.v1..v3 = force components along E1..E3 on the rod at A, w1, w2 moments (0 here)
            loads = {"hinge.v1.lambda": Fx, "hinge.v2.lambda": Fy, "hinge.v3.lambda": z,
                     "hinge.w1.lambda": z, "hinge.w2.lambda": z}
            return states, {"motor": J * al}, loads

        return p["T"], info, f
    raise ValueError(problem)
