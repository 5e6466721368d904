"""Kinematics of an OpenSim model's bodies as CasADi expressions of the coordinates and their rates.

:func:`kinematic_expressions` (recursive from the ground, used by the gait frame function),
:func:`kinematics_by_ad` (AD of the poses, the reference) and :func:`kinematics_function`
(with the velocity Jacobian ``J = d(vbar, omega)/d(pdot)`` of paper eq. 39). The methods of
:class:`~ocp_constraints.biomech.osim_model.OsimModel` with these names call them.
"""
from __future__ import annotations

import casadi as ca

# ``osim`` arguments are :class:`~ocp_constraints.biomech.osim_model.OsimModel` (not imported:
# that module calls this one; annotations stay strings)


def kinematic_expressions(osim: OsimModel, p, pd, pdd, bodies: list[str]) -> dict[str, list]:
    """Per body of ``bodies`` (SX, ground frame): ``R`` (3x3), origin ``x``, ``xbar``, ``vbar``,
    ``omega``, ``abar``, ``alpha`` for coordinates ``p`` and their rates ``pd``, ``pdd``.

    Recursive from the ground, joint by joint: each joint's relative rotation and
    translation are differentiated by AD (they depend on a few coordinates), and the
    rigid-body formulas carry velocities and accelerations outward (``omega_M = omega_F
    + R_F omega_rel``, ``alpha_M = alpha_F + R_F omega_rel' + omega_F x R_F omega_rel``,
    ``a_Y = a_X + alpha x r + omega x (omega x r)`` on one body, plus the Coriolis term
    ``2 omega_F x R_F p_FM'`` across a joint). 9,600 operations for the JW model where AD of
    the poses over all coordinates (:func:`kinematics_by_ad`) takes 18,600 (equal to 1e-15).
    """
    pv = {n: p[i] for i, n in enumerate(osim.coordinate_names)}
    z, zd = ca.vertcat(p, pd), ca.vertcat(pd, pdd)
    zero = ca.DM.zeros(3, 1)
    K = {"ground": (ca.DM.eye(3), zero, zero, zero, zero, zero)}      # R, x, omega, alpha, v, a (origin)

    def moved(state, r):
        """Origin kinematics moved by the body-fixed offset ``r`` (ground components)."""
        R, x, w, al, v, a = state
        return x + r, v + ca.cross(w, r), a + ca.cross(al, r) + ca.cross(w, ca.cross(w, r))

    for name in osim.order:
        j = osim.joints[name]
        R_FM, p_FM = j.transform(j.spatial_values(pv))
        W = ca.reshape(ca.jtimes(ca.vec(R_FM), p, pd), 3, 3) @ R_FM.T
        w_rel = ca.vertcat(W[2, 1], W[0, 2], W[1, 0])            # M relative to F, F components
        al_rel = ca.jtimes(w_rel, z, zd)
        pd_FM = ca.jtimes(p_FM, p, pd)
        pdd_FM = ca.jtimes(pd_FM, z, zd)
        if not j.reversed:
            known = K[j.parent.body]
            R_F = known[0] @ j.parent.R
            x_F, v_F, a_F = moved(known, known[0] @ j.parent.p)
            w_F, al_F = known[2], known[3]
            wr = R_F @ w_rel
            w_M, al_M = w_F + wr, al_F + R_F @ al_rel + ca.cross(w_F, wr)
            d, dd = R_F @ p_FM, R_F @ pd_FM
            x_M, v_M = x_F + d, v_F + ca.cross(w_F, d) + dd
            a_M = a_F + ca.cross(al_F, d) + ca.cross(w_F, ca.cross(w_F, d)) + 2 * ca.cross(w_F, dd) + R_F @ pdd_FM
            R_B = R_F @ R_FM @ j.child.R.T
            frame, body = (R_B, x_M, w_M, al_M, v_M, a_M), j.child
        else:
            known = K[j.child.body]
            R_M = known[0] @ j.child.R
            x_M, v_M, a_M = moved(known, known[0] @ j.child.p)
            w_M, al_M = known[2], known[3]
            R_F = R_M @ R_FM.T
            wr = R_F @ w_rel
            w_F = w_M - wr
            al_F = al_M - R_F @ al_rel - ca.cross(w_F, wr)
            d, dd = R_F @ p_FM, R_F @ pd_FM
            x_F, v_F = x_M - d, v_M - ca.cross(w_F, d) - dd
            a_F = a_M - ca.cross(al_F, d) - ca.cross(w_F, ca.cross(w_F, d)) - 2 * ca.cross(w_F, dd) - R_F @ pdd_FM
            R_B = R_F @ j.parent.R.T
            frame, body = (R_B, x_F, w_F, al_F, v_F, a_F), j.parent
        x_B, v_B, a_B = moved(frame, -(R_B @ body.p))
        K[body.body] = (R_B, x_B, frame[2], frame[3], v_B, a_B)
    out = {k: [] for k in ("R", "x", "xbar", "vbar", "omega", "abar", "alpha")}
    for b in bodies:
        R, x, w, al, v, a = K[b]
        xbar, vbar, abar = moved(K[b], R @ ca.DM(osim.bodies[b].com))
        for k, val in (("R", R), ("x", x), ("xbar", xbar), ("vbar", vbar), ("omega", w), ("abar", abar),
                       ("alpha", al)):
            out[k].append(val)
    return out


def kinematics_by_ad(osim: OsimModel, p, pd, pdd, bodies: list[str]) -> dict[str, list]:
    """As :func:`kinematic_expressions`, by AD of the poses over all coordinates (the reference for
    tests and the Jacobian of :func:`kinematics_function`). Per body of ``bodies`` (SX, ground frame): ``R`` (3x3), origin ``x``, ``xbar``, ``vbar``,
    ``omega``, ``abar``, ``alpha`` for coordinates ``p`` and their rates ``pd``, ``pdd``.

    Derivatives by CasADi AD (``omega = vee(R' R^T)``, rates by ``jtimes`` over ``(p, pd)``).
    """
    names = osim.coordinate_names
    X = osim.poses({n: p[i] for i, n in enumerate(names)})
    nb = len(bodies)
    R = [X[b][0] for b in bodies]
    x = [X[b][1] for b in bodies]
    xbar = [x[k] + R[k] @ ca.DM(osim.bodies[b].com) for k, b in enumerate(bodies)]
    # one forward sweep for all bodies (a sweep per body would differentiate the shared
    # inboard chain once per body: 81,000 instead of 21,000 operations for the JW model)
    S = ca.vertcat(*[ca.vertcat(ca.vec(R[k]), xbar[k]) for k in range(nb)])
    Sd = ca.jtimes(S, p, pd)
    Sdd = ca.jtimes(Sd, ca.vertcat(p, pd), ca.vertcat(pd, pdd))
    out = {"R": R, "x": x, "xbar": xbar, "vbar": [], "omega": [], "abar": [], "alpha": []}
    for k in range(nb):
        Rd, Rdd = ca.reshape(Sd[12 * k:12 * k + 9], 3, 3), ca.reshape(Sdd[12 * k:12 * k + 9], 3, 3)
        W = Rd @ R[k].T                     # omega^ = R' R^T
        Wd = Rdd @ R[k].T                   # (omega')^ = skew part of R'' R^T (R' R'^T is symmetric)
        out["omega"].append(ca.vertcat(W[2, 1], W[0, 2], W[1, 0]))
        out["alpha"].append(0.5 * ca.vertcat(Wd[2, 1] - Wd[1, 2], Wd[0, 2] - Wd[2, 0], Wd[1, 0] - Wd[0, 1]))
        out["vbar"].append(Sd[12 * k + 9:12 * k + 12])
        out["abar"].append(Sdd[12 * k + 9:12 * k + 12])
    return out


def kinematics_function(osim: OsimModel, bodies: list[str] | None = None) -> ca.Function:
    """``(p, pdot, pddot) -> (R, xbar, vbar, omega, abar, alpha, J)`` for ``bodies``.

    Per body (stacked in the given order, ground frame): ``R`` (3x3, column major
    into 9 rows), ``xbar`` centre of mass (m), ``vbar`` (m/s), ``omega`` (rad/s),
    their rates, and ``J = d(vbar, omega)/d(pdot)`` (6 n_bodies x n_coordinates),
    the velocity Jacobian of paper eq. (39). Derivatives by CasADi AD:
    ``omega = vee(R' R^T)``.
    """
    names = osim.coordinate_names
    bodies = bodies or list(osim.bodies)
    p, pd, pdd = (ca.SX.sym(s, len(names)) for s in ("p", "pd", "pdd"))
    K = kinematics_by_ad(osim, p, pd, pdd, bodies)
    u = ca.vertcat(*[ca.vertcat(K["vbar"][i], K["omega"][i]) for i in range(len(bodies))])
    J = ca.jacobian(u, pd)
    return ca.Function("osim_kinematics", [p, pd, pdd],
                       [ca.vertcat(*[ca.vec(R) for R in K["R"]])] + [ca.vertcat(*K[k]) for k in
                                                                     ("xbar", "vbar", "omega", "abar", "alpha")] + [J],
                       ["p", "pdot", "pddot"], ["R", "xbar", "vbar", "omega", "abar", "alpha", "J"])
