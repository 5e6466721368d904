"""Seven optimal-control problems a newcomer writes first, with the public API only (issue 13: "the
result will also be checked on problems that are not in the suite"), each against an independent
reference: Lagrange's equations in minimal coordinates, derived from the bodies' energies and
transcribed in plain CasADi Opti with the same Radau collocation (tests/newcomer_reference.py), and
each problem's constraint loads against Newton-Euler on a body along the solution.

    python scripts/newcomer_problems.py [NAME ...] [--intervals N]

prints per problem: solved?, IPOPT iterations, CPU and wall seconds of ``ocp.solve``, the objective
and the reference's, and the largest load error (relative to the largest load).
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

import ocp_constraints as oc

_spec = importlib.util.spec_from_file_location("newcomer_reference",
                                               Path(__file__).parent.parent / "tests" / "newcomer_reference.py")
ref = importlib.util.module_from_spec(_spec)
sys.modules["newcomer_reference"] = ref          # dataclasses look their module up there
_spec.loader.exec_module(ref)
E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])


def _rod(m, L, axis=0):
    """A slender rod's inertia (kg m^2) along body axis ``axis`` (a small axial moment keeps it physical)."""
    J = np.full(3, m * L**2 / 12)
    J[axis] = 1e-4
    return np.diag(J)


# -- 1. a planar two-link arm to a pose, min effort, joints.revolute ----------------------------------
ARM = dict(m=1.0, L=0.5, T=1.0, start=(-math.pi / 2, -math.pi / 2), goal=(0.3, 1.2))


def arm(free_time: bool = False):
    p = ARM
    model = oc.Model("arm", gravity=(0, -9.81, 0))
    upper = model.add_body("upper", p["m"], _rod(p["m"], p["L"]), rotation="321")
    fore = model.add_body("fore", p["m"], _rod(p["m"], p["L"]), rotation="321")
    oc.joints.revolute(model, "shoulder", upper.point("S", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1))
    oc.joints.revolute(model, "elbow", fore.point("E", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1),
                       other=upper.point("E", (p["L"] / 2, 0, 0)))
    t1, t2 = model.add_input("tau1"), model.add_input("tau2")
    model.add_torque("shoulder_motor", upper, ca.vertcat(0, 0, t1))
    model.add_torque("elbow_motor", fore, ca.vertcat(0, 0, t2), reaction_body=upper)
    if free_time:
        ocp = oc.OptimalControlProblem(model, t_final=1.0, t_final_bounds=(0.2, 3.0))
        ocp.minimize_final_time()
        ocp.minimize_effort(weight=0.01)
        for n in ("tau1", "tau2"):
            ocp.bound(n, -15.0, 15.0)
        goal = (0.0, 0.0)
    else:
        ocp = oc.OptimalControlProblem(model, t_final=p["T"])
        ocp.minimize_effort()
        goal = p["goal"]
    ocp.initial({"upper.psi": p["start"][0], "fore.psi": p["start"][1], "upper.omega_z": 0.0, "fore.omega_z": 0.0})
    ocp.final({"upper.psi": goal[0], "fore.psi": goal[1], "upper.omega_z": 0.0, "fore.omega_z": 0.0})
    return ocp


def arm_system():
    p = ARM
    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 2)
    e = lambda a: ca.vertcat(ca.cos(a), ca.sin(a), 0)  # noqa: E731
    bodies = [ref.RigidBody(p["m"], _rod(p["m"], p["L"]), p["L"] / 2 * e(q[0]), ref.rot3(q[0])),
              ref.RigidBody(p["m"], _rod(p["m"], p["L"]), p["L"] * e(q[0]) + p["L"] / 2 * e(q[1]), ref.rot3(q[1]))]
    s = ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]))
    Q = s.torque_work(0, ca.vertcat(0, 0, w[0] - w[1])) + s.torque_work(1, ca.vertcat(0, 0, w[1]))
    return ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]), Q)


def arm_reference(N, guess=None, free_time=False):
    s, p = arm_system(), ARM
    start = {0: p["start"][0], 1: p["start"][1], 2: 0.0, 3: 0.0}
    if free_time:
        return ref.radau_solve(s, N, 1.0, 0.01 * ca.sumsqr(s.w), start, {0: 0.0, 1: 0.0, 2: 0.0, 3: 0.0},
                               input_bounds=(-15.0, 15.0), guess_q=guess, free_time=(0.2, 3.0), time_weight=1.0)
    return ref.radau_solve(s, N, p["T"], ca.sumsqr(s.w), start, {0: p["goal"][0], 1: p["goal"][1], 2: 0.0, 3: 0.0},
                           guess_q=guess)


def arm_state(sol):
    return np.vstack([sol.sample(n) for n in ("upper.psi", "fore.psi", "upper.omega_z", "fore.omega_z")])


def arm_loads(sol, s=None):
    """Shoulder force on the upper arm = sum of m a_cm - m g over both links (Newton on the two links)."""
    s = s or arm_system()
    X, W = arm_state(sol), np.vstack([sol.sample("tau1"), sol.sample("tau2")])
    return _newton(s, X, W, [0, 1], sol.loads(), "shoulder", [0, 1])


def _newton(s, X, W, bodies, loads, channel, axes):
    """Largest relative error of ``channel``'s force against ``sum m (a_cm - g)`` over ``bodies``."""
    n = s.q.numel()
    qdd = ca.SX.sym("qdd", n)
    acc = []
    for b in bodies:
        v = ca.jtimes(s.bodies[b].x, s.q, s.qd)
        acc.append(s.bodies[b].mass * (ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, qdd) - ca.DM(s.gravity)))
    F = ca.Function("F", [s.q, s.qd, qdd], [sum(acc)])
    dyn = ca.Function("qdd", [s.q, s.qd, s.w], [s.qdd])
    err, big = 0.0, 0.0
    for i in range(X.shape[1]):
        a = dyn(X[:n, i], X[n:, i], W[:, i])
        want = np.asarray(F(X[:n, i], X[n:, i], a)).ravel()
        got = np.array([loads[f"{channel}.F_{c}"][i] for c in "xyz"])
        err, big = max(err, np.abs(got - want)[axes].max()), max(big, np.abs(want).max())
    return err / big


# -- 2. a slider-crank driven by a motor, the loop closed by hand ---------------------------------------
CRANK = dict(r=0.1, l=0.3, m_crank=0.5, m_rod=0.4, m_slider=0.6, load=20.0, T=0.5)


def slider_crank():
    p = CRANK
    model = oc.Model("slider_crank", gravity=(0, -9.81, 0))
    crank = model.add_body("crank", p["m_crank"], _rod(p["m_crank"], p["r"]), rotation="321")
    rod = model.add_body("rod", p["m_rod"], _rod(p["m_rod"], p["l"]), rotation="321")
    slider = model.add_body("slider", p["m_slider"], 1e-3 * np.eye(3), rotation="321")
    oc.joints.revolute(model, "O", crank.point("O", (-p["r"] / 2, 0, 0)), axis=(0, 0, 1))
    oc.joints.revolute(model, "A", rod.point("A", (-p["l"] / 2, 0, 0)), axis=(0, 0, 1),
                       other=crank.point("A", (p["r"] / 2, 0, 0)))
    oc.joints.prismatic(model, "rail", slider.com, axis=(1, 0, 0))
    B = rod.point("B", (p["l"] / 2, 0, 0))
    for k, E in ((0, E1), (1, E2)):        # the closure in the plane (E3 is the revolutes' already)
        model.add_constraint(f"B.v{k + 1}", ca.dot(E, B.v) - ca.dot(E, slider.com.v), joint="B",
                             position=B.position[k] - slider.com.position[k])
    tau = model.add_input("motor")
    model.add_torque("motor", crank, ca.vertcat(0, 0, tau))
    model.add_force("gas", slider.com, ca.vertcat(-p["load"], 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    ocp.initial({"crank.psi": 0.0, "crank.omega_z": 0.0})
    ocp.final({"crank.psi": math.pi, "crank.omega_z": 0.0})
    ocp.minimize_effort()
    return ocp


def crank_system():
    p = CRANK
    q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
    th = q[0]
    A = p["r"] * ca.vertcat(ca.cos(th), ca.sin(th), 0)
    beta = -ca.asin(p["r"] * ca.sin(th) / p["l"])
    d = ca.vertcat(ca.cos(beta), ca.sin(beta), 0)
    xs = ca.vertcat(A[0] + p["l"] * ca.cos(beta), 0, 0)
    bodies = [ref.RigidBody(p["m_crank"], _rod(p["m_crank"], p["r"]), A / 2, ref.rot3(th)),
              ref.RigidBody(p["m_rod"], _rod(p["m_rod"], p["l"]), A + p["l"] / 2 * d, ref.rot3(beta)),
              ref.RigidBody(p["m_slider"], 1e-3 * np.eye(3), xs, ca.DM.eye(3))]
    s = ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]))
    Q = s.torque_work(0, ca.vertcat(0, 0, w[0])) + s.force_work(xs, ca.DM([-p["load"], 0, 0]))
    return ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]), Q)


def crank_reference(N, guess=None):
    s = crank_system()
    return ref.radau_solve(s, N, CRANK["T"], ca.sumsqr(s.w), {0: 0.0, 1: 0.0}, {0: math.pi, 1: 0.0}, guess_q=guess)


def crank_loads(sol):
    """The closure's force on the slider along E1 = m_s a_s + load (Newton on the slider)."""
    s = crank_system()
    X = np.vstack([sol.sample("crank.psi"), sol.sample("crank.omega_z")])
    W = np.atleast_2d(sol.sample("motor"))
    loads = dict(sol.loads())
    loads["B@slider.F_x"] = loads["B@slider.F_x"] - CRANK["load"]   # the applied load, moved to the left side
    return _newton(s, X, W, [2], {k: loads[k] if k in loads else 0 * loads["B@slider.F_x"]
                                  for k in ("B@slider.F_x", "B@slider.F_y", "B@slider.F_z")}, "B@slider", [0])


# -- 3. a spherical pendulum (ball joint by hand) to a target orientation -------------------------------
SPH = dict(m=1.0, L=1.0, T=2.0, goal=(0.6, 0.4, 0.9))


def spherical(initial_orientation: bool = True):
    p = SPH
    model = oc.Model("spherical", gravity=(0, 0, -9.81))
    J = np.diag([p["m"] * p["L"] ** 2 / 12, p["m"] * p["L"] ** 2 / 12, 0.01])
    bob = model.add_body("bob", p["m"], J, rotation="321")
    P = bob.point("P", (0, 0, p["L"] / 2))
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"ball.v{k + 1}", ca.dot(E, P.v), joint="ball", position=P.position[k])
    w = [model.add_input(f"t{c}") for c in "xyz"]
    model.add_torque("motor", bob, ca.vertcat(*w))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    start = {"bob.psi": 0.0, "bob.theta": 0.0, "bob.phi": 0.0} if initial_orientation else {}
    ocp.initial({**start, "bob.omega_x": 0.0, "bob.omega_y": 0.0, "bob.omega_z": 0.0})
    ocp.final({"bob.psi": p["goal"][0], "bob.theta": p["goal"][1], "bob.phi": p["goal"][2],
               "bob.omega_x": 0.0, "bob.omega_y": 0.0, "bob.omega_z": 0.0})
    ocp.minimize_effort()
    return ocp


def spherical_system():
    p = SPH
    q, w = ca.SX.sym("q", 3), ca.SX.sym("w", 3)
    R = ref.rot3(q[0]) @ ref.rot2(q[1]) @ ref.rot1(q[2])
    J = np.diag([p["m"] * p["L"] ** 2 / 12, p["m"] * p["L"] ** 2 / 12, 0.01])
    bodies = [ref.RigidBody(p["m"], J, R @ ca.DM([0, 0, -p["L"] / 2]), R)]
    s = ref.LagrangeSystem(q, w, bodies, np.array([0, 0, -9.81]))
    return ref.LagrangeSystem(q, w, bodies, np.array([0, 0, -9.81]), s.torque_work(0, w))


def spherical_reference(N, guess=None):
    s = spherical_system()
    g = SPH["goal"]
    return ref.radau_solve(s, N, SPH["T"], ca.sumsqr(s.w), {i: 0.0 for i in range(6)},
                           {0: g[0], 1: g[1], 2: g[2], 3: 0.0, 4: 0.0, 5: 0.0}, guess_q=guess)


def spherical_loads(sol):
    s = spherical_system()
    X = np.vstack([sol.sample(n) for n in ("bob.psi", "bob.theta", "bob.phi", "bob.psi_dot", "bob.theta_dot",
                                           "bob.phi_dot")])
    W = np.vstack([sol.sample(f"t{c}") for c in "xyz"])
    return _newton(s, X, W, [0], sol.loads(), "ball", [0, 1, 2])


# -- 4. a cart-pole on library joints with a bound on the hinge force -----------------------------------
CARTPOLE = dict(m_cart=1.0, m_pole=0.5, L=1.0, T=2.0, f_max=12.0)


def cart_pole(bounded: bool = True):
    p = CARTPOLE
    model = oc.Model("cart_pole_joints", gravity=(0, -9.81, 0))
    cart = model.add_body("cart", p["m_cart"], 0.01 * np.eye(3), rotation="321")
    pole = model.add_body("pole", p["m_pole"], _rod(p["m_pole"], p["L"], axis=1), rotation="321")
    oc.joints.prismatic(model, "rail", cart.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "hinge", pole.point("A", (0, p["L"] / 2, 0)), axis=(0, 0, 1), other=cart.com)
    push = model.add_input("push")
    model.add_force("push", cart.com, ca.vertcat(push, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    ocp.initial({"cart.x": 0.0, "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    ocp.final({"cart.x": 0.0, "pole.psi": math.pi, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    ocp.minimize_effort()
    if bounded:
        F = ocp.joint_force("hinge@pole")
        ocp.subject_to(ca.sumsqr(F), -np.inf, p["f_max"] ** 2, "hinge force")
    return ocp


def cart_pole_system():
    p = CARTPOLE
    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 1)
    x, th = q[0], q[1]
    R = ref.rot3(th)
    bodies = [ref.RigidBody(p["m_cart"], 0.01 * np.eye(3), ca.vertcat(x, 0, 0), ca.DM.eye(3)),
              ref.RigidBody(p["m_pole"], _rod(p["m_pole"], p["L"], axis=1),
                            ca.vertcat(x, 0, 0) + R @ ca.DM([0, -p["L"] / 2, 0]), R)]
    s = ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]))
    return ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]), s.force_work(ca.vertcat(x, 0, 0),
                                                                                     ca.vertcat(w[0], 0, 0)))


def cart_pole_hinge_force(s) -> ca.SX:
    """The hinge's force on the pole, ``m (a_cm - g)``, in the minimal system ``s``'s ``q, qd, w``."""
    v = ca.jtimes(s.bodies[1].x, s.q, s.qd)
    return CARTPOLE["m_pole"] * (ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, s.qdd) - ca.DM(s.gravity))


def cart_pole_reference(N, guess=None, bounded=True, **options):
    """``options``: more of ``radau_solve``'s (``degree``, ``mesh``, ``start``)."""
    s, p = cart_pole_system(), CARTPOLE
    path = [(ca.sumsqr(cart_pole_hinge_force(s)), -np.inf, p["f_max"] ** 2)] if bounded else None
    return ref.radau_solve(s, N, p["T"], ca.sumsqr(s.w), {i: 0.0 for i in range(4)},
                           {0: 0.0, 1: math.pi, 2: 0.0, 3: 0.0}, path=path, guess_q=guess, **options)


def cart_pole_loads(sol):
    s = cart_pole_system()
    X = np.vstack([sol.sample(n) for n in ("cart.x", "pole.psi", "cart.vbar_x", "pole.omega_z")])
    return _newton(s, X, np.atleast_2d(sol.sample("push")), [1], sol.loads(), "hinge@pole", [0, 1, 2])


# -- 5. a wheel rolling up a slope, friction cone at the contact ----------------------------------------
WHEEL = dict(m=2.0, R=0.2, slope=math.radians(20.0), mu=0.6, T=1.5, d=1.0)


def _wheel_gravity():
    a = WHEEL["slope"]
    return np.array([-9.81 * math.sin(a), 0.0, -9.81 * math.cos(a)])   # E1 up the slope, E3 its normal


def wheel():
    p = WHEEL
    model = oc.Model("wheel", gravity=tuple(_wheel_gravity()))
    J = p["m"] * p["R"] ** 2 * np.diag([0.25, 0.5, 0.25])
    disk = model.add_body("disk", p["m"], J, rotation="213")      # psi about E2: the rolling angle
    c = disk.com
    # the plane of motion: no E2 motion, turning about E2 only
    model.add_constraint("plane.v2", ca.dot(E2, c.v), joint="plane", position=c.position[1])
    model.add_constraint("plane.w1", ca.dot(E1, disk.omega), joint="plane")
    model.add_constraint("plane.w3", ca.dot(E3, disk.omega), joint="plane")
    # the contact: the material point at the contact has no velocity (normal and along the slope)
    v_contact = c.v + ca.cross(disk.omega, ca.DM([0, 0, -p["R"]]))
    model.add_constraint("contact.t", ca.dot(E1, v_contact), joint="contact")
    model.add_constraint("contact.n", ca.dot(E3, v_contact), joint="contact", position=c.position[2] - p["R"])
    tau = model.add_input("axle")
    model.add_torque("axle", disk, ca.vertcat(0, tau, 0))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    ocp.initial({"disk.x": 0.0, "disk.psi": 0.0, "disk.theta": 0.0, "disk.phi": 0.0, "disk.vbar_x": 0.0})
    ocp.final({"disk.x": p["d"], "disk.vbar_x": 0.0})
    ocp.minimize_effort()
    ocp.friction_cone("contact", p["mu"], normal=(0, 0, 1))
    return ocp


def wheel_system():
    p = WHEEL
    q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
    J = p["m"] * p["R"] ** 2 * np.diag([0.25, 0.5, 0.25])
    bodies = [ref.RigidBody(p["m"], J, ca.vertcat(p["R"] * q[0], 0, p["R"]), ref.rot2(q[0]))]
    s = ref.LagrangeSystem(q, w, bodies, _wheel_gravity())
    return ref.LagrangeSystem(q, w, bodies, _wheel_gravity(), s.torque_work(0, ca.vertcat(0, w[0], 0)))


def wheel_reference(N, guess=None):
    s, p = wheel_system(), WHEEL
    v = ca.jtimes(s.bodies[0].x, s.q, s.qd)
    F = p["m"] * (ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, s.qdd) - ca.DM(s.gravity))
    path = [(F[2], 0.0, np.inf), (F[0] ** 2 + F[1] ** 2 - p["mu"] ** 2 * F[2] ** 2, -np.inf, 0.0)]
    return ref.radau_solve(s, N, p["T"], ca.sumsqr(s.w), {0: 0.0, 1: 0.0}, {0: p["d"] / p["R"], 1: 0.0},
                           path=path, guess_q=guess)


def wheel_loads(sol):
    s = wheel_system()
    X = np.vstack([sol.sample("disk.psi"), sol.sample("disk.psi_dot")])
    return _newton(s, X, np.atleast_2d(sol.sample("axle")), [0], sol.loads(), "contact", [0, 2])


# -- 6. a gantry crane in minimum time, the rope's tension bounded ---------------------------------------
CRANE = dict(m_trolley=10.0, m_load=50.0, L=3.0, d=2.0, f_max=200.0, tension=1.05, swing=0.3)


def crane():
    """Trolley on a rail, load on a rigid rope hinged at the trolley; 2 m in minimum time, rest to rest, the
    trolley's force and the load's swing bounded, the rope's pull on the load at most 1.05 of its weight (in N^2)."""
    p = CRANE
    model = oc.Model("crane", gravity=(0, -9.81, 0))
    trolley = model.add_body("trolley", p["m_trolley"], 0.1 * np.eye(3), rotation="321")
    load = model.add_body("load", p["m_load"], 0.5 * np.eye(3), rotation="321")
    oc.joints.prismatic(model, "rail", trolley.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "rope", load.point("hook", (0, p["L"], 0)), other=trolley.com)
    model.add_force("drive", trolley.com, ca.vertcat(model.add_input("F"), 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=4.0, t_final_bounds=(0.5, 20.0))
    ocp.initial({"trolley.x": 0.0, "load.psi": 0.0, "trolley.vbar_x": 0.0, "load.omega_z": 0.0})
    ocp.final({"trolley.x": p["d"], "load.psi": 0.0, "trolley.vbar_x": 0.0, "load.omega_z": 0.0})
    ocp.bound("F", -p["f_max"], p["f_max"])
    ocp.bound("load.psi", -p["swing"], p["swing"])
    ocp.subject_to(ca.sumsqr(ocp.joint_force("rope@load")), -np.inf, (p["tension"] * p["m_load"] * 9.81) ** 2,
                   "rope tension")
    ocp.minimize_final_time()
    ocp.minimize_effort(weight=1e-6)
    return ocp


def crane_system():
    p = CRANE
    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 1)
    x, swing = q[0], q[1]
    bodies = [ref.RigidBody(p["m_trolley"], 0.1 * np.eye(3), ca.vertcat(x, 0, 0), ca.DM.eye(3)),
              ref.RigidBody(p["m_load"], 0.5 * np.eye(3), ca.vertcat(x, 0, 0) + ref.rot3(swing) @ ca.DM([0, -p["L"], 0]),
                            ref.rot3(swing))]
    s = ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]))
    return ref.LagrangeSystem(q, w, bodies, np.array([0, -9.81, 0]), s.force_work(ca.vertcat(x, 0, 0),
                                                                                     ca.vertcat(w[0], 0, 0)))


def crane_reference(N, guess=None):
    s, p = crane_system(), CRANE
    v = ca.jtimes(s.bodies[1].x, s.q, s.qd)
    F = p["m_load"] * (ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, s.qdd) - ca.DM(s.gravity))   # the rope's pull
    path = [(ca.sumsqr(F), -np.inf, (p["tension"] * p["m_load"] * 9.81) ** 2), (s.q[1], -p["swing"], p["swing"])]
    return ref.radau_solve(s, N, 4.0, 1e-6 * ca.sumsqr(s.w), {i: 0.0 for i in range(4)}, {0: p["d"], 1: 0.0, 2: 0.0, 3: 0.0},
                           input_bounds=(-p["f_max"], p["f_max"]), path=path, guess_q=guess, free_time=(0.5, 20.0),
                           time_weight=1.0)


def crane_loads(sol):
    s = crane_system()
    X = np.vstack([sol.sample(n) for n in ("trolley.x", "load.psi", "trolley.vbar_x", "load.omega_z")])
    return _newton(s, X, np.atleast_2d(sol.sample("F")), [1], sol.loads(), "rope@load", [0, 1, 2])


PROBLEMS = {
    "arm": (arm, arm_reference, arm_loads, lambda sol: arm_state(sol)[:2]),
    "slider_crank": (slider_crank, crank_reference, crank_loads,
                     lambda sol: np.vstack([sol.sample("crank.psi")])),
    "spherical": (spherical, spherical_reference, spherical_loads,
                  lambda sol: np.vstack([sol.sample(n) for n in ("bob.psi", "bob.theta", "bob.phi")])),
    "cart_pole": (cart_pole, cart_pole_reference, cart_pole_loads,
                  lambda sol: np.vstack([sol.sample(n) for n in ("cart.x", "pole.psi")])),
    "wheel": (wheel, wheel_reference, wheel_loads, lambda sol: np.vstack([sol.sample("disk.psi")])),
    "arm_free_time": (lambda: arm(free_time=True), lambda N, guess=None: arm_reference(N, guess, free_time=True),
                      arm_loads, lambda sol: arm_state(sol)[:2]),
    "crane": (crane, crane_reference, crane_loads, lambda sol: np.vstack([sol.sample(n) for n in ("trolley.x", "load.psi")])),
}


def run(name: str, N: int) -> dict:
    build, reference, loads, state = PROBLEMS[name]
    ocp = build()
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        sol = ocp.solve(oc.Radau(N, degree=3))
    except oc.OCPSolveError as exc:
        return {"problem": name, "solved": False, "status": str(exc)[:200],
                "cpu": time.process_time() - c0, "wall": time.perf_counter() - w0}
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    r_default = reference(N)
    q = state(sol)
    n = q.shape[0]
    r_from_ours = reference(N, guess=lambda s: q[:n])
    return {"problem": name, "solved": sol.success, "iterations": sol.iterations, "cpu": cpu, "wall": wall,
            "objective": sol.objective, "reference": r_from_ours["objective"],
            "reference_default_guess": r_default["objective"], "load_error": loads(sol),
            "coordinates": ocp.nlp_coordinates}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=list(PROBLEMS))
    parser.add_argument("--intervals", type=int, default=20)
    args = parser.parse_args()
    print("| problem | solved | iterations | CPU s | wall s | objective | reference (from ours / own guess) | "
          "load error |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.names:
        r = run(name, args.intervals)
        if not r["solved"] or "objective" not in r:
            print(f"| {name} | no: {r.get('status')} | | {r['cpu']:.2f} | {r['wall']:.2f} | | | |")
            continue
        print(f"| {name} ({r['coordinates']}) | yes | {r['iterations']} | {r['cpu']:.2f} | {r['wall']:.2f} | "
              f"{r['objective']:.10g} | {r['reference']:.10g} / {r['reference_default_guess']:.6g} | "
              f"{r['load_error']:.1e} |")


if __name__ == "__main__":
    main()
