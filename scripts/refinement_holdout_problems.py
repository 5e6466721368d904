"""The textbook holdouts of scripts/refinement_holdouts.py (issue 19): problems written from scratch through the
public API (``import ocp_constraints as oc``), each with a reference derived independently (closed forms, exact
piecewise-polynomial integrals, root-finding), none used to tune the refinement.

Problems (rigid bodies with hand-written constraints, paper eq. 25, so the NLP is in maximal coordinates and
every multiplier is a constraint force or moment, eq. 26, checked against Newton-Euler by hand):

- ``bang_bang``: a block on a rail pushed by F (|F| <= F_MAX) at a point H above its center, rest to rest over D
  in minimum time. Closed form: F = F_MAX up to T/2, -F_MAX after, T = 2 sqrt(M D / F_MAX); the rail's normal
  force is M g and its moment about E3 is H F (it balances the push's moment): a multiplier that jumps.
- ``clipped``: the same block, rest to rest over D in a fixed T, least integral of F^2 with |F| <= U below the
  unconstrained peak 6 M D / T^2: F = clip(c2 (T/2 - t), -U, U) (Pontryagin: the saturated linear costate);
  c2 by root-finding on x(T) = D (brentq on the exact piecewise-polynomial integral). F kinks at the junctions.
- ``hinge``: a rod of mass M and length L turning about the fixed vertical axis E3 through its end A (three
  hinge forces and two hinge moments written in the fixed basis), driven by a torque tau about E3; a full turn
  rest to rest in T, least integral of tau^2, with the hinge's radial (centripetal) force bounded: a path
  constraint on the multipliers, M (L/2) omega^2 <= M (L/2) W^2, active along the middle of the turn. Closed form
  (the minimum-effort double integrator under a speed limit): alpha = A (T1 - t) up to T1 = 1.5 (T - THETA / W),
  A = 2 W / T1^2, then 0 at the limit, then mirrored; tau = J_A alpha, J_A = M L^2 / 3; hinge force on the rod
  along the rod -M (L/2) omega^2, across it M (L/2) alpha, vertical M g; hinge moment -M g (L/2) e2.

``bang_bang_asym``: bang_bang with -F_MAX <= F <= 2 F_MAX, the switch at T/3 (bang_bang's T/2 is a mesh point of
the first mesh and of every even uniform one, whatever T).

``clipped_upper``: the clipped push with its upper bound only (F <= CLU_U): saturated at the start, one junction,
then free; F = min(CLU_U, a - b t), (a, b) by fsolve on x(T) = D, v(T) = 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import casadi as ca
import numpy as np
from scipy.interpolate import PPoly
from scipy.optimize import brentq

import ocp_constraints as oc

G = 9.81
E1, E2, E3 = ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1])

# -- bang_bang and clipped: a block on a rail -----------------------------------------------------------------
M, H = 1.0, 1.0                      # kg; m: height of the push's point above the center of mass
BB_D, BB_FMAX = 1.0, 5.0             # m, N
BB_T = 2.0 * math.sqrt(M * BB_D / BB_FMAX)
CL_D, CL_T, CL_U = 4.0, 2.0, 5.0     # m, s, N (unconstrained peak 6 M D / T^2 = 6 N)
CLU_U = 5.4                          # N, clipped_upper's bound (at 5.0 its junction would fall on t = 0.2 s exactly,
                                     # a mesh point of the first mesh and of every uniform one tried)
# -- hinge: a rod turning about E3 ------------------------------------------------------------------------------
ROD_M, ROD_L = 1.0, 1.0              # kg, m
HG_THETA, HG_T, HG_W = 2 * math.pi, 2.0, 4.0     # rad, s, rad/s (unconstrained peak 1.5 THETA / T = 4.71 rad/s)
J_A = ROD_M * ROD_L**2 / 3


def _block_model(name: str):
    """A block of mass M on a rail along E1 (gravity -E2 presses it on the rail; it does not turn), pushed
    along E1 by input F at the point H above its center. Returns the model and the push's point."""
    model = oc.Model(name, gravity=(0.0, -G, 0.0))
    block = model.add_body("block", M, np.diag([0.01, 0.01, 0.01]), rotation="321")
    model.add_constraint("rail.v2", ca.dot(E2, block.com.v), joint="rail", position=block.com.position[1])
    model.add_constraint("rail.v3", ca.dot(E3, block.com.v), joint="rail", position=block.com.position[2])
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"rail.w{k + 1}", ca.dot(E, block.omega), joint="rail")
    push = block.point("P", (0.0, H, 0.0))
    model.add_force("push", push, ca.vertcat(model.add_input("F"), 0, 0))
    return model


def bang_bang_problem() -> oc.OptimalControlProblem:
    """Minimum-time rest-to-rest of the block over BB_D with |F| <= BB_FMAX (free final time)."""
    ocp = oc.OptimalControlProblem(_block_model("holdout_bang_bang"), t_final=1.5, t_final_bounds=(0.2, 5.0))
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
    ocp.final({"block.x": BB_D, "block.vbar_x": 0.0})
    ocp.bound("F", -BB_FMAX, BB_FMAX)
    ocp.minimize_final_time()
    return ocp


def bang_bang_asym_problem() -> oc.OptimalControlProblem:
    """bang_bang with -BB_FMAX <= F <= 2 BB_FMAX: the switch at T/3, not a mesh point of the first mesh (10 equal
    intervals; bang_bang's T/2 is one, whatever T)."""
    ocp = bang_bang_problem()
    ocp.bound("F", -BB_FMAX, 2 * BB_FMAX)
    return ocp


def clipped_problem() -> oc.OptimalControlProblem:
    """Least integral of F^2, rest to rest over CL_D in CL_T, |F| <= CL_U (saturated at both ends)."""
    ocp = oc.OptimalControlProblem(_block_model("holdout_clipped"), t_final=CL_T)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0, "block.psi": 0.0, "block.theta": 0.0, "block.phi": 0.0})
    ocp.final({"block.x": CL_D, "block.vbar_x": 0.0})
    ocp.bound("F", -CL_U, CL_U)
    ocp.minimize_effort(["F"])
    return ocp


def clipped_upper_problem() -> oc.OptimalControlProblem:
    """The clipped problem with the upper bound only (F <= CLU_U): saturated at the start, then free to the end.
    One junction, where F kinks; no run of free points between two bounds (which the refinement reads as a jump)."""
    ocp = clipped_problem()
    ocp.bound("F", -np.inf, CLU_U)
    return ocp


def hinge_problem() -> oc.OptimalControlProblem:
    """A rod (center of mass L/2 from its end A on the axis) turning one full turn about E3 in HG_T, rest to
    rest, least integral of tau^2, the hinge's radial force at most ROD_M (L/2) HG_W^2 (a path constraint on
    the multipliers: the rod's speed limit seen through the load that holds it on its circle)."""
    model = oc.Model("holdout_hinge", gravity=(0.0, 0.0, -G))
    # A slender rod along its body axis e1 (1e-4 kg m^2 about it keeps the inertia positive definite).
    rod = model.add_body("rod", ROD_M, np.diag([1e-4, ROD_M * ROD_L**2 / 12, ROD_M * ROD_L**2 / 12]), rotation="321")
    A = rod.point("A", (-ROD_L / 2, 0.0, 0.0))
    # The hinge: A stays at the origin, the rod turns about E3 only (fixed-basis components, as cart_pole_by_hand).
    for k, E in enumerate((E1, E2, E3)):
        model.add_constraint(f"hinge.v{k + 1}", ca.dot(E, A.v), joint="hinge", position=A.position[k])
    model.add_constraint("hinge.w1", ca.dot(E1, rod.omega), joint="hinge")
    model.add_constraint("hinge.w2", ca.dot(E2, rod.omega), joint="hinge")
    model.add_torque("drive", rod, ca.vertcat(0, 0, model.add_input("tau")))
    ocp = oc.OptimalControlProblem(model, t_final=HG_T)
    ocp.initial({"rod.psi": 0.0, "rod.theta": 0.0, "rod.phi": 0.0, "rod.omega_z": 0.0})
    ocp.final({"rod.psi": HG_THETA, "rod.omega_z": 0.0})
    psi = ocp.quantity("rod.psi")
    # The hinge force on the rod along the rod (e1 = cos psi E1 + sin psi E2): the centripetal load, negative.
    radial = ocp.multiplier("hinge.v1") * ca.cos(psi) + ocp.multiplier("hinge.v2") * ca.sin(psi)
    ocp.subject_to(-radial, -np.inf, ROD_M * ROD_L / 2 * HG_W**2, "hinge radial force")
    ocp.set_guess("rod.psi", lambda t: HG_THETA * np.asarray(t) / HG_T)
    ocp.minimize_effort(["tau"])
    return ocp


# -- references -------------------------------------------------------------------------------------------------
def _integrated(breaks, pieces) -> tuple[PPoly, PPoly, PPoly]:
    """A piecewise polynomial (``pieces``: highest-power-first local coefficients per piece) and its first and
    second antiderivatives from 0, exact (scipy's PPoly keeps each piece's polynomial)."""
    p = PPoly(np.array(pieces, dtype=float).T, np.asarray(breaks, dtype=float))
    return p, p.antiderivative(1), p.antiderivative(2)


def _clipped_switch(c2: float) -> float:
    """Where the clipped line c2 (T/2 - t) leaves the bound U."""
    return CL_T / 2 - CL_U / c2


def _clipped_push(c2: float) -> tuple[PPoly, PPoly, PPoly]:
    t1 = _clipped_switch(c2)
    return _integrated([0.0, t1, CL_T - t1, CL_T],
                       [[0.0, CL_U / M], [-c2 / M, CL_U / M], [0.0, -CL_U / M]])


def clipped_c2() -> float:
    """c2 of F = clip(c2 (T/2 - t), -U, U) with x(T) = D: brentq on the exact x(T) of the clipped line."""
    lo = 2 * CL_U / CL_T * (1 + 1e-12)           # just saturating at t = 0
    return brentq(lambda c2: float(_clipped_push(c2)[2](CL_T)) - CL_D, lo, 1e6 * lo, xtol=1e-15, rtol=1e-15)


def _upper_push(a: float, b: float) -> tuple[PPoly, PPoly, PPoly]:
    t1 = (a - CLU_U) / b
    return _integrated([0.0, t1, CL_T], [[0.0, CLU_U / M], [-b / M, (a - b * t1) / M]])


def clipped_upper_line() -> tuple[float, float]:
    """(a, b) of F = min(CLU_U, a - b t) that ends at x = CL_D, v = 0 (fsolve from the unconstrained line)."""
    from scipy.optimize import fsolve

    def miss(ab):
        _, v, x = _upper_push(*ab)
        return [float(x(CL_T)) - CL_D, float(v(CL_T))]
    unconstrained = 6 * M * CL_D / CL_T**2
    ab, info, ok, msg = fsolve(miss, [unconstrained, 2 * unconstrained / CL_T], xtol=1e-14, full_output=True)
    if ok != 1 or max(abs(m) for m in miss(ab)) > 1e-12:
        raise RuntimeError(f"clipped_upper reference: fsolve did not converge ({msg})")
    return float(ab[0]), float(ab[1])


def _hinge_law() -> tuple[float, float]:
    t1 = 1.5 * (HG_T - HG_THETA / HG_W)
    return t1, 2 * HG_W / t1**2


@dataclass
class Reference:
    """Every named quantity as a function of absolute time (s), and what the solve must give."""
    values: Callable[[np.ndarray], dict[str, np.ndarray]]
    t_final: float
    objective: float
    free_time: bool
    switches: tuple[float, ...]      # times (s) where the input jumps or kinks
    jumps: bool = False              # whether the input (and a multiplier) jumps there (bang-bang)


def _block_values(accel: tuple[PPoly, PPoly, PPoly], T: float) -> Callable:
    def values(t):
        t = np.clip(np.asarray(t, float), 0.0, T)
        a, v, x = (np.asarray(f(t)) for f in accel)
        F = M * a
        z = 0 * t
        out = {n: z for n in ("block.y", "block.z", "block.psi", "block.theta", "block.phi", "block.vbar_y",
                              "block.vbar_z", "block.omega_x", "block.omega_y", "block.omega_z")}
        # Newton-Euler on the block (no rotation): along E2 the rail holds the weight; about E3 at the center
        # its moment balances the push's, (H E2) x (F E1) = -H F E3.
        out.update({"block.x": x, "block.vbar_x": v, "F": F, "rail.v2.lambda": M * G + z, "rail.v3.lambda": z,
                    "rail.w1.lambda": z, "rail.w2.lambda": z, "rail.w3.lambda": H * F})
        return out
    return values


def bang_bang_reference() -> Reference:
    T = BB_T
    accel = _integrated([0.0, T / 2, T], [[BB_FMAX / M], [-BB_FMAX / M]])
    return Reference(_block_values(accel, T), T, T, True, (T / 2,), jumps=True)


def bang_bang_asym_reference() -> Reference:
    # 2 F_MAX / M for t1, then -F_MAX / M for 2 t1 (same peak speed); D = 1.5 (2 F_MAX / M) t1^2.
    t1 = math.sqrt(BB_D / (1.5 * 2 * BB_FMAX / M))
    accel = _integrated([0.0, t1, 3 * t1], [[2 * BB_FMAX / M], [-BB_FMAX / M]])
    return Reference(_block_values(accel, 3 * t1), 3 * t1, 3 * t1, True, (t1,), jumps=True)


def clipped_reference() -> Reference:
    c2 = clipped_c2()
    t1 = _clipped_switch(c2)
    J = 2 * (CL_U**2 * t1 + c2**2 * (CL_T / 2 - t1) ** 3 / 3)
    return Reference(_block_values(_clipped_push(c2), CL_T), CL_T, J, False, (t1, CL_T - t1))


def clipped_upper_reference() -> Reference:
    a, b = clipped_upper_line()
    t1 = (a - CLU_U) / b
    # int_0^t1 U^2 dt + int_t1^T (a - b t)^2 dt, the second by the antiderivative of the square.
    J = CLU_U**2 * t1 + ((a - b * t1) ** 3 - (a - b * CL_T) ** 3) / (3 * b)
    return Reference(_block_values(_upper_push(a, b), CL_T), CL_T, J, False, (t1,))


def hinge_reference() -> Reference:
    t1, A = _hinge_law()
    alpha, omega, theta = _integrated([0.0, t1, HG_T - t1, HG_T], [[-A, A * t1], [0.0, 0.0], [-A, 0.0]])
    r = ROD_L / 2

    def values(t):
        t = np.clip(np.asarray(t, float), 0.0, HG_T)
        al, om, th = (np.asarray(f(t)) for f in (alpha, omega, theta))
        c, s, z = np.cos(th), np.sin(th), 0 * t
        along, across = -ROD_M * r * om**2, ROD_M * r * al          # hinge force on the rod along e1, e2
        return {"rod.x": r * c, "rod.y": r * s, "rod.z": z, "rod.psi": th, "rod.theta": z, "rod.phi": z,
                "rod.vbar_x": -r * om * s, "rod.vbar_y": r * om * c, "rod.vbar_z": z,
                "rod.omega_x": z, "rod.omega_y": z, "rod.omega_z": om, "tau": J_A * al,
                "hinge.v1.lambda": along * c - across * s, "hinge.v2.lambda": along * s + across * c,
                "hinge.v3.lambda": ROD_M * G + z,
                # Moments about the center: M_c + (-r e1) x (M g E3) = 0 -> M_c = -M g r e2, e2 = (-s, c, 0).
                "hinge.w1.lambda": ROD_M * G * r * s, "hinge.w2.lambda": -ROD_M * G * r * c}
    J = J_A**2 * 2 * A**2 * t1**3 / 3
    return Reference(values, HG_T, J, False, (t1, HG_T - t1))


PROBLEMS = {"bang_bang": (bang_bang_problem, bang_bang_reference),
            "bang_bang_asym": (bang_bang_asym_problem, bang_bang_asym_reference),
            "clipped": (clipped_problem, clipped_reference),
            "hinge": (hinge_problem, hinge_reference),
            "clipped_upper": (clipped_upper_problem, clipped_upper_reference)}
