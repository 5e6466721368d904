"""URDF import (``oc.load_urdf``): links become bodies, joints the joint library's joints.

Parser: `yourdfpy <https://github.com/clemense/yourdfpy>`_ (the optional extra ``urdf``). It
reads links, inertials, joints, axes, limits and mimic tags into plain dataclasses with no
mesh loading and no scene graph unless asked for (lxml only), validates the file, and is kept
up to date; urchin (the maintained fork of urdfpy) builds trimesh objects for every link on
load, which an import of the inertial and kinematic data does not need.

The mapping (every load then comes from Lagrange's prescription, paper eq. 26):

* a link with mass becomes a body (unit quaternion rotation, since robots turn far): body basis
  = the link frame, center of mass = the ``<inertial>`` origin, inertia rotated from the
  inertial frame into the link frame (``R I R^T``; URDF inertias are about the center of mass);
* a link without mass (no ``<inertial>`` or mass 0, e.g. ``tool0``) is a frame of the body (or
  the ground) it is fixed to; it must reach it through ``fixed`` joints;
* ``revolute`` and ``continuous`` -> :func:`~.joints_spatial.revolute` about the joint axis,
  ``prismatic`` -> :func:`~.joints_spatial.prismatic`, ``fixed`` -> :func:`~.joints_spatial.weld`
  (or, with ``merge_fixed=True``, the child's inertia merged into its parent, as Pinocchio does);
  each acts at the child link's origin (the joint frame) and on the parent at the same point;
* the root link: a massless root (``world``) is the ground; with ``base="fixed"`` a root with
  mass is welded to the ground (joint ``ground_weld``, at ``base_pose``); with ``base="ground"``
  the root and the links fixed to it are the ground (no body, no reaction reported);
* every movable joint gets an actuator input ``<joint>.tau`` (N m about, or N along, the joint
  axis, equal and opposite on child and parent); ``<limit>`` gives :attr:`Robot.limits`,
  :attr:`Robot.input_bounds` (for ``problem.bound``) and :meth:`Robot.limit_constraints`.

``<dynamics>`` damping and friction, ``<mimic>`` couplings (a mimic joint is imported as an
independent joint with its own input) and ``<transmission>`` are not imported.
Names are made identifiers (``base_link-base_fixed_joint`` -> ``base_link_base_fixed_joint``);
:attr:`Robot.urdf_names` maps back.
"""
from __future__ import annotations

import re
from pathlib import Path

import casadi as ca
import numpy as np

from ..errors import DataFileError, ModelError
from . import joints_spatial as js
from .model import Model
from .urdf_robot import MOVABLE, JointLimit, Robot, RobotJoint

__all__ = ["load_urdf", "Robot", "RobotJoint", "JointLimit"]


def load_urdf(path: str | Path, *, base: str = "fixed", base_pose=None, merge_fixed: bool = False,
              gravity=(0.0, 0.0, -9.81), actuated: bool = True, name: str | None = None) -> Robot:
    """Build a :class:`Robot` (its ``model`` a Model of the joint library) from the URDF file ``path``.

    ``base``: ``"fixed"`` (a root link with mass is welded to the ground, joint ``ground_weld``) or
    ``"ground"`` (the root link and the links fixed to it are the ground). ``base_pose``: 4x4 pose
    of the root link in the fixed basis (default the identity). ``merge_fixed``: merge the
    children of ``fixed`` joints into their parents (fewer bodies; those joints report no load).
    ``actuated``: an input ``<joint>.tau`` per movable joint. Gravity in m/s^2, fixed basis.
    """
    if base not in ("fixed", "ground"):
        raise ModelError(f"load_urdf: base must be 'fixed' or 'ground', got {base!r}")
    T_base = np.eye(4) if base_pose is None else np.asarray(base_pose, float)
    if T_base.shape != (4, 4) or not np.allclose(T_base[:3, :3] @ T_base[:3, :3].T, np.eye(3), atol=1e-9):
        raise ModelError(f"load_urdf: base_pose must be a 4x4 homogeneous transform, got {base_pose!r}")
    urdf = _parse(Path(path))
    links = {lk.name: lk for lk in urdf.links}
    children: dict[str, list] = {n: [] for n in links}
    for j in urdf.joints:
        for end in (j.parent, j.child):
            if end not in links:
                raise DataFileError(path, f"joint '{j.name}' names link '{end}', which the file does not define")
        children[j.parent].append(j)
        if j.type not in MOVABLE + ("fixed",):
            raise ModelError(f"{path}: joint '{j.name}' is of type '{j.type}'; load_urdf imports revolute, "
                             "continuous, prismatic and fixed joints (replace it, or build that part with oc.joints)")
    roots = [n for n in links if n not in {j.child for j in urdf.joints}]
    if len(roots) != 1:
        raise DataFileError(path, f"a URDF tree has one root link; found {roots or 'none (a loop)'}")

    def mass(link) -> float:
        return float(link.inertial.mass) if link.inertial is not None and link.inertial.mass else 0.0

    # Pass 1: which body (None: the ground) each link belongs to, and its pose there.
    root = roots[0]
    owner: dict[str, str | None] = {root: None if (mass(links[root]) <= 0 or base == "ground") else root}
    pose = {root: T_base if owner[root] is None else np.eye(4)}
    joint_list, order = [], [root]
    for link in order:
        for j in children[link]:
            T = pose[link] @ _origin(j)
            c = j.child
            if j.type == "fixed" and (mass(links[c]) <= 0 or merge_fixed or (owner[link] is None and base == "ground")):
                owner[c], pose[c] = owner[link], T
            elif mass(links[c]) <= 0:
                raise ModelError(f"{path}: link '{c}' has no mass but is moved by the {j.type} joint '{j.name}': a "
                                 "body needs a mass; give it an <inertial>, or make the joint fixed")
            else:
                owner[c], pose[c] = c, np.eye(4)
                joint_list.append((j, owner[link], T))
            order.append(c)

    # Pass 2: bodies (inertias of merged links summed about the group's center of mass).
    names = {}
    model = Model(name or _ident(urdf.name or Path(path).stem), gravity=gravity,
                  parameters={"urdf": str(Path(path).resolve())})
    com, notes = {}, []
    for body in dict.fromkeys(o for o in owner.values() if o is not None):
        parts = [(mass(links[lk]), pose[lk], links[lk].inertial) for lk in order if owner[lk] == body and mass(links[lk]) > 0]
        m, c, J = _combine(parts)
        names[body] = _ident(body)
        b = model.add_body(names[body], m, J, "quaternion", check_inertia=False)
        if b.inertia_warning:
            notes.append(b.inertia_warning)
        com[names[body]] = c
    if not names:
        raise ModelError(f"{path}: no link has a mass: nothing moves (give the links <inertial> elements)")
    if owner[root] is not None:
        joint_list.insert(0, (None, None, T_base))

    # Pass 3: joints and actuators.
    robot_joints, movable = {}, []
    for j, parent, T in joint_list:
        child = names[root] if j is None else names[j.child]
        jname = "ground_weld" if j is None else _ident(j.name)
        kind = "fixed" if j is None else j.type
        axis = np.array([1.0, 0, 0]) if j is None or j.axis is None else np.asarray(j.axis, float)
        axis = axis / np.linalg.norm(axis)
        lim = j.limit if j is not None else None
        limit = JointLimit(*(float(v) if v is not None else d for v, d in (
            (getattr(lim, "lower", None), -np.inf), (getattr(lim, "upper", None), np.inf),
            (getattr(lim, "velocity", None), np.inf), (getattr(lim, "effort", None), np.inf))))
        if kind == "continuous":
            limit = JointLimit(velocity=limit.velocity, effort=limit.effort)
        if kind in MOVABLE and (limit.lower == limit.upper or limit.velocity == 0 or limit.effort == 0):
            notes.append(f"joint '{_ident(j.name)}': <limit lower={limit.lower:g} upper={limit.upper:g} "
                         f"velocity={limit.velocity:g} effort={limit.effort:g}> read as unset where zero (an "
                         "exporter's default; such a joint could not move)")
            limit = JointLimit(*(limit.lower, limit.upper) if limit.lower < limit.upper else (-np.inf, np.inf),
                               limit.velocity or np.inf, limit.effort or np.inf)
        pname = None if parent is None else names[parent]
        rj = RobotJoint(jname, "ground_weld" if j is None else j.name, kind, pname, child, T, axis, limit)
        _add_joint(model, rj, com)
        if kind in MOVABLE:
            rj.index = len(movable)
            movable.append(jname)
            if actuated:
                rj.input = _add_actuator(model, rj, com)
            if kind != "prismatic" and limit.upper - limit.lower >= 2 * np.pi:
                notes.append(f"joint '{jname}': range [{limit.lower:g}, {limit.upper:g}] rad is a turn or more; "
                             "it does not restrict the orientation, so no position limit is imposed")
        if j is not None and j.mimic is not None:
            notes.append(f"joint '{jname}' mimics '{j.mimic.joint}' in the URDF; imported as an independent joint")
        robot_joints[jname] = rj
    frames = {lk: (None if owner[lk] is None else names[owner[lk]], pose[lk]) for lk in order}
    urdf_names = {**{v: k for k, v in names.items()}, **{_ident(j.name): j.name for j in urdf.joints}}
    return Robot(model, robot_joints, movable, frames, urdf_names, com, notes)


# -- helpers -------------------------------------------------------------------------------------
def _parse(path: Path):
    try:
        import yourdfpy
    except ImportError:
        raise ModelError("load_urdf needs the URDF parser yourdfpy: pip install 'ocp_constraints[urdf]'") from None
    if not path.is_file():
        raise DataFileError(path, "no such file (give the path of a .urdf file)")
    from lxml import etree

    try:                                   # yourdfpy recovers from broken XML; a broken file is refused
        etree.parse(str(path), etree.XMLParser(recover=False))
    except etree.XMLSyntaxError as exc:
        raise DataFileError(path, f"is not a readable URDF (XML: {exc.msg})", line=exc.lineno) from exc
    try:
        return yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False, load_collision_meshes=False).robot
    except Exception as exc:  # noqa: BLE001 - lxml, yourdfpy: any parse failure is a bad file
        raise DataFileError(path, f"is not a readable URDF ({type(exc).__name__}: {exc})") from exc


def _ident(name: str) -> str:
    s = re.sub(r"\W", "_", str(name))
    return s if s and not s[0].isdigit() else f"l_{s}"


def _origin(j) -> np.ndarray:
    return np.eye(4) if j.origin is None else np.asarray(j.origin, float)


def _combine(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, center of mass and inertia about it (group frame) of links ``(mass, pose, inertial)``."""
    m = sum(p[0] for p in parts)
    cs, Js = [], []
    for mk, T, inertial in parts:
        Ti = T @ (np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, float))
        I = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, float)
        cs.append(Ti[:3, 3])
        Js.append(Ti[:3, :3] @ I @ Ti[:3, :3].T)
    c = sum(p[0] * ck for p, ck in zip(parts, cs)) / m
    J = sum(Jk + p[0] * (np.dot(ck - c, ck - c) * np.eye(3) - np.outer(ck - c, ck - c))
            for p, ck, Jk in zip(parts, cs, Js))
    return m, c, 0.5 * (J + J.T)


def _points(model: Model, rj: RobotJoint, com: dict):
    """The joint's point on the child (its link origin) and on the parent (or the ground anchor)."""
    child = model.bodies[rj.child].point(rj.name, -com[rj.child])
    if rj.parent is None:
        return child, None, rj.origin[:3, 3]
    return child, model.bodies[rj.parent].point(rj.name, rj.origin[:3, 3] - com[rj.parent]), None


def _add_joint(model: Model, rj: RobotJoint, com: dict) -> None:
    child, other, anchor = _points(model, rj, com)
    R = rj.origin[:3, :3]
    if rj.type in ("revolute", "continuous"):
        js.revolute(model, rj.name, child, axis=R @ rj.axis, anchor=anchor, body_axis=rj.axis, other=other)
    elif rj.type == "prismatic":
        js.prismatic(model, rj.name, child, other, axis=R @ rj.axis, anchor=anchor, relative_rotation=R)
    else:
        js.weld(model, rj.name, child, other, anchor=anchor, relative_rotation=R)


def _add_actuator(model: Model, rj: RobotJoint, com: dict) -> str:
    """Input ``<joint>.tau``: a torque about (revolute) or force along (prismatic) the axis, equal and
    opposite on the parent; the force's two halves act along one line (the axis through the joint)."""
    tau = model.add_input(f"{rj.name}.tau")
    child = model.bodies[rj.child]
    a = child.Q @ ca.DM(rj.axis)
    parent = None if rj.parent is None else model.bodies[rj.parent]
    if rj.type == "prismatic":
        model.add_force(f"{rj.name}.drive", child.points[rj.name], tau * a)
        if parent is not None:
            model.add_force(f"{rj.name}.drive_reaction", parent.points[rj.name], -tau * a)
    else:
        model.add_torque(f"{rj.name}.drive", child, tau * a, reaction_body=parent)
    return f"{rj.name}.tau"
