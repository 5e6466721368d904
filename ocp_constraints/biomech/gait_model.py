"""Our constraint model of an OpenSim model (step 1 of :mod:`ocp_constraints.biomech.gait`).

The OpenSim model's segments become our bodies (unit quaternions, so no Euler
singularity). Every joint's six relative directions are written at velocity level from
the bodies' angular velocities and point velocities: ``s_i' = g^i . R_F^T (omega_C -
omega_P)`` for the three rotation axes (dual Euler basis of the joint, paper eq. 11) and
``s' = A^-1 R_F^T (v_M - v_F - omega_P x (x_M - x_F))`` for the translations. A
direction with a constant function, a direction coupled to a coordinate by a spline
(gait2354 knee translations) and a *locked* coordinate become named constraints of the
core (``<joint>.<axis>``, ``<joint>.<coordinate>``); each free coordinate becomes an
actuator input whose load pair has power ``tau q'`` (a torque along ``g^i`` or a force
along the dual translation axis).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np


from ..mechanics.constraints import Joint
from ..mechanics.model import Model
from .osim_model import OsimJoint, OsimModel, axis_rotation
from ..errors import OsimModelError


# -- 1. our model from the OpenSim model -------------------------------------------------------

@dataclass
class JointInfo:
    """What the constraint model did with one OpenSim joint."""

    name: str
    parent: str
    child: str
    constraints: list[str] = field(default_factory=list)
    inputs: list[str] = field(default_factory=list)


def _rotation_values(j: OsimJoint, R_FM) -> list:
    """Spatial rotation values ``s1, s2, s3`` of joint ``j`` from its relative rotation ``R_FM``."""
    axes = [np.asarray(a.axis) for a in j.axes[:3]]
    consts = [a.function.is_constant or not a.coordinates for a in j.axes[:3]]
    values = [float(a.function(None)) if consts[i] else None for i, a in enumerate(j.axes[:3])]
    driven = [i for i in range(3) if not consts[i]]
    if len(driven) == 1:
        i = driven[0]
        before = ca.DM.eye(3)
        for m in range(i):
            before = before @ axis_rotation(values[m], axes[m])
        after = ca.DM.eye(3)
        for m in range(i + 1, 3):
            after = after @ axis_rotation(values[m], axes[m])
        Rk = before.T @ R_FM @ after.T
        a = axes[i]
        b = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        b /= np.linalg.norm(b)
        Rb = Rk @ ca.DM(b)
        values[i] = ca.atan2(ca.dot(ca.DM(np.cross(a, b)), Rb), ca.dot(ca.DM(b), Rb))
    elif len(driven) >= 2:
        if max(abs(axes[0] @ axes[1]), abs(axes[0] @ axes[2]), abs(axes[1] @ axes[2])) > 1e-9:
            raise OsimModelError(f"joint '{j.name}': several driven rotations about non-orthogonal axes "
                                 "are not supported")
        sign = 1.0 if np.linalg.det(np.column_stack(axes)) > 0 else -1.0
        S = ca.DM(np.column_stack([axes[0], axes[1], sign * axes[2]]))
        M = S.T @ R_FM @ S          # = Rx(s1) Ry(s2) Rz(sign s3)
        ext = [ca.atan2(-M[1, 2], M[2, 2]), ca.atan2(M[0, 2], ca.sqrt(M[0, 0] ** 2 + M[0, 1] ** 2)),
               sign * ca.atan2(-M[0, 1], M[0, 0])]
        values = [ext[i] if values[i] is None else values[i] for i in range(3)]
    return values


def _add_joint(model: Model, osim: OsimModel, j: OsimJoint) -> JointInfo:
    """Constraints and inputs of one joint (see the module docstring, step 1)."""
    bodies = model.bodies
    P = bodies.get(j.parent.body)
    C = bodies[j.child.body]
    info = JointInfo(j.name, j.parent.body, j.child.body)

    def frame(body, fr, tag):
        if body is None:
            return ca.DM(fr.R), ca.DM(fr.p), None
        pt = body.point(f"{j.name}_{tag}", fr.p - osim.bodies[body.name].com)
        return body.Q @ ca.DM(fr.R), pt.position, pt

    R_F, x_F, OF = frame(P, j.parent, "F")
    R_M, x_M, OM = frame(C, j.child, "M")
    model.joints[j.name] = Joint(j.name, points={C.name: OM, **({P.name: OF} if P is not None else {})})
    R_FM = R_F.T @ R_M
    A_t = np.column_stack([a.axis for a in j.axes[3:]])
    if abs(np.linalg.det(A_t)) < 1e-9:
        raise OsimModelError(f"joint '{j.name}': the translation axes are not independent")
    A_inv = ca.DM(np.linalg.inv(A_t))
    r = x_M - x_F
    s = _rotation_values(j, R_FM) + [A_inv[i, :] @ (R_F.T @ r) for i in range(3)]
    a = [ca.DM(ax.axis) for ax in j.axes[:3]]
    R1 = axis_rotation(s[0], j.axes[0].axis)
    g = [a[0], R1 @ a[1], R1 @ axis_rotation(s[1], j.axes[1].axis) @ a[2]]
    vol = ca.dot(g[0], ca.cross(g[1], g[2]))
    dual = [ca.cross(g[1], g[2]) / vol, ca.cross(g[2], g[0]) / vol, ca.cross(g[0], g[1]) / vol]
    w_P = P.omega if P is not None else ca.DM.zeros(3, 1)
    v_F = OF.v if OF is not None else ca.DM.zeros(3, 1)
    w_rel = R_F.T @ (C.omega - w_P)
    v_rel = R_F.T @ (OM.v - v_F - ca.cross(w_P, r))
    sdot = [ca.dot(dual[i], w_rel) for i in range(3)] + [A_inv[i, :] @ v_rel for i in range(3)]
    # each coordinate's defining axis: the first whose function is affine in it alone
    defining, pvals, pdots = {}, {}, {}
    for cname in j.coordinates:
        for i, ax in enumerate(j.axes):
            aff = ax.function.affine()
            if ax.coordinates == [cname] and aff is not None and aff[0] != 0 and i not in defining.values():
                defining[cname] = i
                pvals[cname] = (s[i] - aff[1]) / aff[0]
                pdots[cname] = sdot[i] / aff[0]
                break
        else:
            raise OsimModelError(f"joint '{j.name}': coordinate '{cname}' drives no axis linearly; "
                                 "it cannot be recovered from the body poses")
    # constrained or coupled directions (Lagrange's prescription gives their loads)
    for i, ax in enumerate(j.axes):
        if i in defining.values():
            continue
        expr = sdot[i]
        if ax.coordinates and not ax.function.is_constant:
            c = ax.coordinates[0]
            x = ca.SX.sym("x")
            slope = ca.substitute(ca.jacobian(ax.function(x), x), x, pvals[c])
            expr = expr - slope * pdots[c]
        name = f"{j.name}.{ax.name}"
        model.add_constraint(name, expr, joint=j.name)
        info.constraints.append(name)
    for cname in j.coordinates:
        i = defining[cname]
        if osim.coordinates[cname].locked:
            name = f"{j.name}.{cname}"
            model.add_constraint(name, pdots[cname], joint=j.name)
            info.constraints.append(name)
            continue
        tau = model.add_input(cname)
        slope = j.axes[i].function.affine()[0]
        if i < 3:
            model.add_torque(f"{cname}.torque", C, tau / slope * (R_F @ dual[i]), reaction_body=P)
        else:
            F = tau / slope * (R_F @ A_inv[i - 3, :].T)
            model.add_force(f"{cname}.force@{C.name}", OM, F)
            if P is not None:
                model.add_force(f"{cname}.force@{P.name}", OF, -F)
                model.add_torque(f"{cname}.arm@{P.name}", P, -ca.cross(r, F))
        info.inputs.append(cname)
    return info


def constraint_model(osim: OsimModel) -> tuple[Model, dict[str, JointInfo]]:
    """Our :class:`Model` of an OpenSim model: all bodies, every joint as constraints + inputs."""
    model = Model(osim.name.replace("-", "_") or "osim", gravity=tuple(osim.gravity))
    model.warnings = []
    for b in osim.bodies.values():
        # OpenSim accepts inertias that break the triangle inequality (JW 'toes'); so do we
        # here, explicitly, to reproduce its results, and say so in the summary.
        body = model.add_body(b.name, b.mass, b.inertia, rotation="quaternion", check_inertia=False)
        if body.inertia_warning:
            model.warnings.append(f"{osim.path}: {body.inertia_warning}, as OpenSim does")
    return model, {name: _add_joint(model, osim, osim.joints[name]) for name in osim.order}


