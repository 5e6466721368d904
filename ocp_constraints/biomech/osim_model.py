"""OpenSim models (``.osim``, 4.x document format) without the OpenSim package.

Parses bodies (mass, centre of mass, inertia about the centre of mass in the body
frame), the joint tree (CustomJoint with Constant, LinearFunction, SimmSpline,
NaturalCubicSpline and MultiplierFunction coordinate functions; PinJoint, SliderJoint,
WeldJoint) and gives forward kinematics as CasADi expressions: for coordinate values
``p`` (and rates, accelerations by automatic differentiation) the pose, velocity and
acceleration of every body in the ground frame, i.e. our coordinates (``xbar``,
rotation) and speeds (``vbar``, ``omega``) and their rates.

Conventions copied from OpenSim/Simbody (checked against their sources):

- A CustomJoint's SpatialTransform maps coordinates to six spatial values ``s``;
  ``R_FM = R(s1, a1) R(s2, a2) R(s3, a3)`` (a body-fixed sequence about the three
  rotation axes given in the parent joint frame F), ``p_FM = s4 a4 + s5 a5 + s6 a6``
  in F (Simbody ``FunctionBasedImpl::calcMobilizerTransformFromQ``).
- PhysicalOffsetFrame ``orientation`` is a body-fixed X-Y-Z sequence.
- SimmSpline is the Forsythe-Malcolm-Moler cubic spline (third derivatives at the ends
  from divided differences, *not* natural end conditions), extrapolated linearly.
- A joint whose child is nearer the ground in the tree than its parent (JW's knee:
  parent ``tibial_tray``, child ``femoral_component``) is used reversed, as Simbody does;
  its coordinates keep their meaning (the pose of F relative to M).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from ..errors import OsimModelError
from .osim_functions import Constant, LinearFunction, OsimFunction, _floats, parse_function  # noqa: F401


# -- rotations -------------------------------------------------------------------------------

def axis_rotation(angle, axis) -> ca.SX:
    """Rotation by ``angle`` about the unit vector ``axis`` (Rodrigues)."""
    a = np.asarray(axis, float)
    K = ca.DM([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return ca.DM.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * (K @ K)


def body_fixed_xyz(angles) -> np.ndarray:
    """OpenSim frame orientation: body-fixed X-Y-Z, ``R = Rx(a) Ry(b) Rz(c)``."""
    R = axis_rotation(angles[0], [1, 0, 0]) @ axis_rotation(angles[1], [0, 1, 0]) @ axis_rotation(angles[2], [0, 0, 1])
    return np.asarray(ca.DM(R))


# -- model structure ----------------------------------------------------------------------------

@dataclass
class TransformAxis:
    """One of the six spatial values of a joint: ``s = function(coordinate)`` along ``axis``."""

    name: str
    rotation: bool
    axis: np.ndarray
    coordinates: list[str]
    function: OsimFunction


@dataclass
class Coordinate:
    name: str
    joint: str
    rotational: bool
    default: float
    locked: bool
    range: tuple[float, float]


@dataclass
class Frame:
    """A frame fixed in a body: rotation ``R`` and origin ``p`` in the body frame (m)."""

    body: str
    R: np.ndarray
    p: np.ndarray


@dataclass
class OsimBody:
    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass
class OsimJoint:
    """A joint: child frame M moves relative to parent frame F by the six transform axes."""

    name: str
    kind: str
    parent: Frame
    child: Frame
    axes: list[TransformAxis]
    coordinates: list[str]
    reversed: bool = False

    def spatial_values(self, p: dict) -> list:
        """The six values ``s_i = f_i(coordinate)`` (rad, m) for coordinate values ``p``."""
        out = []
        for ax in self.axes:
            if ax.function.is_constant or not ax.coordinates:
                out.append(ax.function(None) if ax.function.is_constant else ca.DM(0))
            else:
                out.append(ax.function(p[ax.coordinates[0]]))
        return out

    def transform(self, s) -> tuple[ca.SX, ca.SX]:
        """``R_FM`` and ``p_FM`` (in F) from the six spatial values."""
        R = ca.DM.eye(3)
        for i in range(3):
            R = R @ axis_rotation(s[i], self.axes[i].axis)
        pos = sum((s[3 + i] * ca.DM(self.axes[3 + i].axis) for i in range(3)), ca.DM.zeros(3, 1))
        return R, pos


@dataclass
class OsimModel:
    """Bodies, joints and coordinates of an .osim model (SI units)."""

    path: str
    name: str
    gravity: np.ndarray
    bodies: dict[str, OsimBody]
    joints: dict[str, OsimJoint]
    coordinates: dict[str, Coordinate]
    order: list[str] = field(default_factory=list)  # joints in tree order from the ground

    @property
    def coordinate_names(self) -> list[str]:
        return list(self.coordinates)

    def joint_of(self, body: str) -> OsimJoint:
        """The joint that places ``body`` in the tree (its inboard joint)."""
        for j in self.joints.values():
            if (j.child.body if not j.reversed else j.parent.body) == body:
                return j
        raise OsimModelError(f"{self.path}: body '{body}' has no joint")

    def outboard(self, j: OsimJoint) -> str:
        return j.parent.body if j.reversed else j.child.body

    def inboard(self, j: OsimJoint) -> str:
        return j.child.body if j.reversed else j.parent.body

    def subtree(self, body: str) -> list[str]:
        """``body`` and every body outboard of it, in tree order."""
        out = [body]
        for name in self.order:
            j = self.joints[name]
            if self.inboard(j) in out and self.outboard(j) not in out:
                out.append(self.outboard(j))
        return out

    # -- kinematics ------------------------------------------------------------------------
    def poses(self, p: dict) -> dict[str, tuple]:
        """Body frame rotation ``R`` (body -> ground) and origin ``x`` (m) for coordinates ``p``."""
        X = {"ground": (ca.DM.eye(3), ca.DM.zeros(3, 1))}
        for name in self.order:
            j = self.joints[name]
            R_FM, p_FM = j.transform(j.spatial_values(p))
            if not j.reversed:
                Rp, xp = X[j.parent.body]
                R_F, x_F = Rp @ j.parent.R, xp + Rp @ j.parent.p
                R_M, x_M = R_F @ R_FM, x_F + R_F @ p_FM
                R_B = R_M @ j.child.R.T
                X[j.child.body] = (R_B, x_M - R_B @ j.child.p)
            else:
                Rc, xc = X[j.child.body]
                R_M, x_M = Rc @ j.child.R, xc + Rc @ j.child.p
                R_F = R_M @ R_FM.T
                x_F = x_M - R_F @ p_FM
                R_B = R_F @ j.parent.R.T
                X[j.parent.body] = (R_B, x_F - R_B @ j.parent.p)
        X.pop("ground")
        return X

    def kinematic_expressions(self, p, pd, pdd, bodies: list[str]) -> dict[str, list]:
        """Per body: ``R``, ``x``, ``xbar``, ``vbar``, ``omega``, ``abar``, ``alpha`` (SX, ground frame),
        recursive from the ground (:func:`.osim_kinematics.kinematic_expressions`)."""
        from .osim_kinematics import kinematic_expressions

        return kinematic_expressions(self, p, pd, pdd, bodies)

    def kinematics_by_ad(self, p, pd, pdd, bodies: list[str]) -> dict[str, list]:
        """As :meth:`kinematic_expressions`, by AD of the poses (:func:`.osim_kinematics.kinematics_by_ad`)."""
        from .osim_kinematics import kinematics_by_ad

        return kinematics_by_ad(self, p, pd, pdd, bodies)

    def kinematics_function(self, bodies: list[str] | None = None) -> ca.Function:
        """``(p, pdot, pddot) -> (R, xbar, vbar, omega, abar, alpha, J)`` for ``bodies``
        (:func:`.osim_kinematics.kinematics_function`; ``J``: paper eq. 39)."""
        from .osim_kinematics import kinematics_function

        return kinematics_function(self, bodies)


# -- parsing ------------------------------------------------------------------------------------

def _vec(elem, tag: str, where: str, n: int = 3, default=None) -> np.ndarray:
    text = elem.findtext(tag)
    if text is None:
        if default is not None:
            return np.asarray(default, float)
        raise OsimModelError(f"{where}: missing <{tag}>")
    v = _floats(text, f"{where} <{tag}>")
    if v.size != n:
        raise OsimModelError(f"{where}: <{tag}> must hold {n} numbers, got {v.size}")
    return v


def _body_of(path_text: str) -> str:
    s = (path_text or "").strip().rstrip("/")
    return "ground" if s in ("/ground", "ground", "../ground") else s.split("/")[-1]


def _frame(joint: ET.Element, socket: str, where: str, bodies) -> Frame:
    ref = (joint.findtext(socket) or "").strip()
    if not ref:
        raise OsimModelError(f"{where}: missing <{socket}>")
    frames = joint.find("frames")
    if frames is not None:
        for f in frames:
            if f.get("name") == ref.split("/")[-1]:
                body = _body_of(f.findtext("socket_parent"))
                w = f"{where} frame '{ref}'"
                return Frame(body, body_fixed_xyz(_vec(f, "orientation", w)), _vec(f, "translation", w))
    body = _body_of(ref)
    if body != "ground" and body not in bodies:
        raise OsimModelError(f"{where}: <{socket}> '{ref}' is neither a frame of the joint nor a body")
    return Frame(body, np.eye(3), np.zeros(3))


def _default_axes(kind: str, coords: list[str]) -> list[TransformAxis]:
    """PinJoint (rotation about F's z), SliderJoint (along F's x), WeldJoint as transform axes."""
    E = np.eye(3)
    rot = [E[2], E[0], E[1]]
    axes = [TransformAxis(f"rotation{i + 1}", True, rot[i], [], Constant(0.0)) for i in range(3)]
    axes += [TransformAxis(f"translation{i + 1}", False, E[i], [], Constant(0.0)) for i in range(3)]
    if kind == "PinJoint":
        axes[0] = TransformAxis("rotation1", True, E[2], coords[:1], LinearFunction(1.0, 0.0))
    elif kind == "SliderJoint":
        axes[3] = TransformAxis("translation1", False, E[0], coords[:1], LinearFunction(1.0, 0.0))
    return axes


_XML: dict[str, ET.Element] = {}     # the last model file parsed in this process, by the SHA-256 of its bytes


def model_xml(path) -> ET.Element:
    """The root element of the ``.osim`` file ``path``, parsed once per process for the same bytes: the
    knee pipeline reads the model for the inverse dynamics and again for the muscles' parameters (0.05 s of
    CPU each for JW's 0.9 MB). Keyed by content, so an edited file is parsed again. Callers only read it.
    Raises ``OSError`` / ``ET.ParseError`` as ``ET.parse``."""
    import hashlib

    data = Path(path).read_bytes()
    key = hashlib.sha256(data).hexdigest()
    if key not in _XML:
        root = ET.fromstring(data)
        _XML.clear()
        _XML[key] = root
    return _XML[key]


def load_osim(path) -> OsimModel:
    """Read an OpenSim 4.x ``.osim`` model (see the module docstring for what is supported)."""
    p = Path(path)
    try:
        root = model_xml(p)
    except (OSError, ET.ParseError) as exc:
        raise OsimModelError(f"{p}: cannot read the model: {exc}") from exc
    version = int(root.get("Version", "0") or 0)
    if version < 40000:
        raise OsimModelError(f"{p}: document version {version} is older than OpenSim 4.0 (40000); "
                             "open and save it once with OpenSim 4.x")
    m = root.find("Model")
    if m is None:
        raise OsimModelError(f"{p}: no <Model> element")
    bodies: dict[str, OsimBody] = {}
    for b in m.iterfind("BodySet/objects/Body"):
        w = f"{p}: body '{b.get('name')}'"
        I = _vec(b, "inertia", w, 6)
        J = np.array([[I[0], I[3], I[4]], [I[3], I[1], I[5]], [I[4], I[5], I[2]]])
        bodies[b.get("name")] = OsimBody(b.get("name"), float(_vec(b, "mass", w, 1)[0]), _vec(b, "mass_center", w), J)
    joints: dict[str, OsimJoint] = {}
    coordinates: dict[str, Coordinate] = {}
    for j in m.find("JointSet/objects") if m.find("JointSet/objects") is not None else []:
        name, kind = j.get("name"), j.tag
        w = f"{p}: joint '{name}' ({kind})"
        if kind not in ("CustomJoint", "PinJoint", "SliderJoint", "WeldJoint"):
            raise OsimModelError(f"{w}: joint type not supported (CustomJoint, PinJoint, SliderJoint, WeldJoint are)")
        coords = []
        for c in j.iterfind("coordinates/Coordinate"):
            rng = _floats(c.findtext("range") or "0 0", w)
            locked = (c.findtext("locked") or "false").strip().lower() == "true"
            coords.append(Coordinate(c.get("name"), name, True, float(_floats(c.findtext("default_value") or "0", w)[0]),
                                     locked, (float(rng[0]), float(rng[1]))))
        if kind == "CustomJoint":
            axes = []
            st = j.find("SpatialTransform")
            if st is None:
                raise OsimModelError(f"{w}: missing <SpatialTransform>")
            for k, ta in enumerate(st.findall("TransformAxis")):
                fn = [e for e in ta if e.tag not in ("coordinates", "axis")]
                cn = (ta.findtext("coordinates") or "").split()
                wa = f"{w} axis '{ta.get('name')}'"
                if len(cn) > 1:
                    raise OsimModelError(f"{wa}: functions of several coordinates are not supported")
                func = parse_function(fn[0], wa) if fn else (LinearFunction(1.0, 0.0) if cn else Constant(0.0))
                a = _vec(ta, "axis", wa)
                if np.linalg.norm(a) == 0:
                    raise OsimModelError(f"{wa}: zero axis")
                axes.append(TransformAxis(ta.get("name"), k < 3, a / np.linalg.norm(a), cn, func))
            if len(axes) != 6:
                raise OsimModelError(f"{w}: SpatialTransform must have 6 TransformAxis elements, has {len(axes)}")
        else:
            axes = _default_axes(kind, [c.name for c in coords])
        for c in coords:
            first = next((ax for ax in axes if c.name in ax.coordinates), None)
            if first is None:
                raise OsimModelError(f"{w}: coordinate '{c.name}' drives no transform axis")
            c.rotational = first.rotation
            coordinates[c.name] = c
        joints[name] = OsimJoint(name, kind, _frame(j, "socket_parent_frame", w, bodies),
                                 _frame(j, "socket_child_frame", w, bodies), axes, [c.name for c in coords])
    g = _vec(m, "gravity", f"{p}: model", default=(0, -9.80665, 0))
    model = OsimModel(str(p), m.get("name", p.stem), g, bodies, joints, coordinates)
    _order_tree(model)
    return model


def _order_tree(model: OsimModel) -> None:
    """Tree order from the ground; joints whose child is already placed are reversed."""
    placed, order, todo = {"ground"}, [], list(model.joints.values())
    while todo:
        progress = False
        for j in list(todo):
            if j.parent.body in placed and j.child.body not in placed:
                placed.add(j.child.body)
            elif j.child.body in placed and j.parent.body not in placed:
                j.reversed = True
                placed.add(j.parent.body)
            elif j.parent.body in placed and j.child.body in placed:
                raise OsimModelError(f"{model.path}: joint '{j.name}' closes a loop; only trees are supported")
            else:
                continue
            order.append(j.name)
            todo.remove(j)
            progress = True
        if not progress:
            names = ", ".join(j.name for j in todo)
            raise OsimModelError(f"{model.path}: joint(s) {names} are not connected to the ground")
    missing = [b for b in model.bodies if b not in placed]
    if missing:
        raise OsimModelError(f"{model.path}: body(ies) {missing} have no joint")
    model.order = order
