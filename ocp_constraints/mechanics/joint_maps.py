"""What a library joint's constraints leave free: its parameterization by joint coordinates.

A joint of :mod:`~ocp_constraints.mechanics.joints_spatial` restricts the relative motion of
its body to a known family: a revolute joint leaves one rotation about its axis, a
prismatic joint one translation along its axis, a weld nothing. In joint coordinates the
body's pose is an explicit function of its base's pose and those coordinates (the
coordinates ``q^Gamma`` of paper sec. 5, eqs. 34-37), every constraint of the joint holds
identically, and its multipliers drop out of the motion: they follow from
``Phi_Gamma = lambda A_Gamma`` (eqs. 38-44), see :mod:`~ocp_constraints.mechanics.generalized`.

Each joint function records its :class:`JointMap` on the model (``model.joint_maps``, by
joint name). A constraint written by hand records none and stays a constraint with its
multiplier: nothing here is a special path, only a choice of coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .bodies import Point

#: joint kind -> the name of each joint coordinate
KINDS = {"revolute": ("angle",), "prismatic": ("distance",), "weld": ()}
#: joint kind -> the suffixes of the constraints its parameterization satisfies identically
SUFFIXES = {"revolute": ("v1", "v2", "v3", "w1", "w2"), "prismatic": ("n1", "n2", "w1", "w2", "w3"),
            "weld": ("v1", "v2", "v3", "w1", "w2", "w3")}


@dataclass(eq=False)
class JointMap:
    """The parameterization of one joint: ``point`` (on the moving body) follows the base.

    ``kind``: ``"revolute"`` (``Q_1 = Q_2 R(n, s) R0``, ``x_C1 = x_C2``), ``"prismatic"``
    (``Q_1 = Q_2 R0``, ``x_C1 = x_C2 + s Q_2 n``) or ``"weld"`` (``Q_1 = Q_2 R0``,
    ``x_C1 = x_C2``). ``other`` is the base's point (None: the ground, at ``anchor``);
    ``axis`` ``n`` is in the base basis, ``R0`` the body basis in the base basis at ``s = 0``.
    ``constraints``: the names of the joint's scalar constraints that hold identically.
    """

    joint: str
    kind: str
    point: Point
    other: Point | None
    anchor: np.ndarray
    axis: np.ndarray
    R0: np.ndarray
    constraints: tuple[str, ...]

    @property
    def coordinate_names(self) -> list[str]:
        return [f"{self.joint}.{c}" for c in KINDS[self.kind]]


def record(model, name: str, kind: str, point: Point, other: Point | None, anchor, axis=None, R0=None,
           body_axis=None) -> None:
    """Record on ``model`` the parameterization of joint ``name`` (called by the joint functions
    after they added the joint's constraints). For a revolute joint whose ``body_axis`` differs
    from ``axis``, ``R0`` is the smallest rotation taking the body axis onto the axis."""
    n = np.array([0.0, 0.0, 1.0]) if axis is None else np.asarray(axis, float).ravel()
    if R0 is None:
        R0 = np.eye(3) if body_axis is None else _aligning_rotation(np.asarray(body_axis, float).ravel(), n)
    a = np.zeros(3) if anchor is None else np.asarray(anchor, float).ravel()
    # Only the constraints this joint function wrote: any other constraint grouped under the same
    # joint name (written by hand before or after) stays a constraint.
    names = tuple(f"{name}.{suffix}" for suffix in SUFFIXES[kind])
    maps = model.__dict__.setdefault("joint_maps", {})
    # A second joint function called with the same joint name adds constraints to the group:
    # no single known family then, so the group stays constraints with multipliers.
    if name in maps:
        maps[name] = None
        return
    maps[name] = JointMap(name, kind, point, other, a, n, np.asarray(R0, float), names)


def _aligning_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` onto unit vector ``b`` (Rodrigues)."""
    v, c = np.cross(a, b), float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        if c > 0:
            return np.eye(3)
        k = np.eye(3)[int(np.argmin(np.abs(a)))]
        axis = np.cross(a, k) / np.linalg.norm(np.cross(a, k))
        return 2 * np.outer(axis, axis) - np.eye(3)
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1 + c)


def axis_rotation(n, s) -> ca.SX:
    """``R(n, s)``: rotation by angle ``s`` (rad) about the unit vector ``n`` (Rodrigues)."""
    n = ca.DM(np.asarray(n, float).reshape(3, 1))
    K = ca.skew(n)
    return ca.SX.eye(3) + ca.sin(s) * K + (1 - ca.cos(s)) * (K @ K)
