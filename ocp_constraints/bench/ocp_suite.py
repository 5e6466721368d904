"""The user-problem suite, our side: each problem written with the public API as a user would.

Bodies with their own rotation parameters, joints from :mod:`ocp_constraints.joints` or
constraints written by hand with ``model.add_constraint``, an
:class:`~ocp_constraints.OptimalControlProblem` with boundary values of the coordinates the
task is about, bounds, path constraints and an effort objective, and no guess (or the guess
of one coordinate). The planar problems are here, the spatial ones (rolling disk, quadrotor
with a load, walker) in :mod:`.ocp_suite_3d`. The numbers are in :mod:`.ocp_suite_params`;
the independent minimal-coordinate formulation of each problem is in :mod:`.ocp_suite_minimal`.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

import ocp_constraints as oc

from . import ocp_suite_params as P

E1, E2, E3 = (ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1]))


def rod_inertia(m: float, length: float, axis: int) -> np.ndarray:
    """A thin uniform rod along body axis ``axis`` (0, 1, 2): m l^2 / 12 about the normals (kg m^2)."""
    d = np.full(3, m * length**2 / 12)
    d[axis] = 0.0
    return np.diag(d)


def acrobot(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """Two rods hinged at the origin (shoulder, passive) and to each other (elbow, motor torque),
    swinging in the E1-E2 plane; from hanging at rest to upright at rest, min int tau^2 with
    |tau| <= tau_max. Each rod hangs along its body -e2 at psi = 0 (3-2-1 angles)."""
    p = P.ACROBOT
    model = oc.Model("acrobot", gravity=(0.0, -P.G, 0.0))
    upper = model.add_body("upper", p["m1"], rod_inertia(p["m1"], p["l1"], 1), rotation="321")
    lower = model.add_body("lower", p["m2"], rod_inertia(p["m2"], p["l2"], 1), rotation="321")
    oc.joints.revolute(model, "shoulder", upper.point("top", (0, p["l1"] / 2, 0)))
    oc.joints.revolute(model, "elbow", lower.point("top", (0, p["l2"] / 2, 0)),
                       other=upper.point("bottom", (0, -p["l1"] / 2, 0)))
    tau = model.add_input("elbow_motor")
    model.add_torque("elbow_motor", lower, ca.vertcat(0, 0, tau), reaction_body=upper)
    ocp = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    rest = {"upper.psi_dot": 0.0, "lower.psi_dot": 0.0}
    ocp.initial({"upper.psi": 0.0, "lower.psi": 0.0, **rest})
    ocp.final({"upper.psi": math.pi, "lower.psi": math.pi, **rest})
    ocp.bound("elbow_motor", -p["tau_max"], p["tau_max"])
    ocp.minimize_effort()
    return ocp


def cart_double_pendulum(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """A cart on a rail along E1 (prismatic joint to ground) carrying two rods in a chain; a push
    on the cart swings both rods from hanging to upright, rest to rest, cart back at the start."""
    p = P.CART_DOUBLE
    model = oc.Model("cart_double_pendulum", gravity=(0.0, -P.G, 0.0))
    cart = model.add_body("cart", p["m0"], np.diag([0.01, 0.01, 0.01]), rotation="321")
    rod1 = model.add_body("rod1", p["m1"], rod_inertia(p["m1"], p["l1"], 1), rotation="321")
    rod2 = model.add_body("rod2", p["m2"], rod_inertia(p["m2"], p["l2"], 1), rotation="321")
    oc.joints.prismatic(model, "rail", cart.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "hinge1", rod1.point("top", (0, p["l1"] / 2, 0)), other=cart.com)
    oc.joints.revolute(model, "hinge2", rod2.point("top", (0, p["l2"] / 2, 0)),
                       other=rod1.point("bottom", (0, -p["l1"] / 2, 0)))
    push = model.add_input("push")
    model.add_force("push", cart.com, ca.vertcat(push, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    rest = {"cart.vbar_x": 0.0, "rod1.psi_dot": 0.0, "rod2.psi_dot": 0.0}
    ocp.initial({"cart.x": 0.0, "rod1.psi": 0.0, "rod2.psi": 0.0, **rest})
    ocp.final({"cart.x": 0.0, "rod1.psi": math.pi, "rod2.psi": math.pi, **rest})
    ocp.bound("push", -p["f_max"], p["f_max"])
    ocp.bound("cart.x", -p["x_max"], p["x_max"])
    ocp.minimize_effort()
    return ocp


def four_bar(coordinates: str = "maximal") -> oc.OptimalControlProblem:
    """Crank, coupler and rocker in the E1-E2 plane (each rod along its body e1): revolute joints
    crank-ground at O, coupler-crank at A, rocker-ground at D, and at B a point-on-line joint
    (coupler-rocker, the loop's last pin: its in-plane components only, so no redundancy). A
    motor turns the crank one turn in T, rest to rest, min int tau^2, with the pin force at B
    bounded: |F_B| <= f_pin_max."""
    p = P.FOUR_BAR
    model = oc.Model("four_bar", gravity=(0.0, -P.G, 0.0))
    bars = {}
    for name, length in (("crank", p["a"]), ("coupler", p["b"]), ("rocker", p["c"])):
        m = p["rho"] * length
        bars[name] = model.add_body(name, m, rod_inertia(m, length, 0), rotation="321")
    crank, coupler, rocker = bars["crank"], bars["coupler"], bars["rocker"]
    oc.joints.revolute(model, "O", crank.point("O", (-p["a"] / 2, 0, 0)))
    oc.joints.revolute(model, "A", coupler.point("A", (-p["b"] / 2, 0, 0)), other=crank.point("A", (p["a"] / 2, 0, 0)))
    oc.joints.revolute(model, "D", rocker.point("D", (-p["c"] / 2, 0, 0)), anchor=(p["d"], 0, 0))
    oc.joints.point_on_line(model, "B", rocker.point("B", (p["c"] / 2, 0, 0)), other=coupler.point("B", (p["b"] / 2, 0, 0)),
                            axis=(0, 0, 1))
    motor = model.add_input("motor")
    model.add_torque("motor", crank, ca.vertcat(0, 0, motor))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    ocp.initial({"crank.psi": 0.0, "crank.psi_dot": 0.0})
    ocp.final({"crank.psi": 2 * math.pi, "crank.psi_dot": 0.0})
    # The one guess: the rocker stands about upright. Without it the assembly is searched from
    # every body at the origin, and the pre-solve check finds none (it reports the constraints violated).
    ocp.set_guess("rocker.psi", lambda t: np.full_like(t, math.pi / 2))
    F = ocp.joint_force("B@rocker")
    ocp.subject_to(ca.sumsqr(F), -np.inf, p["f_pin_max"] ** 2, "pin force at B")
    ocp.minimize_effort()
    return ocp
