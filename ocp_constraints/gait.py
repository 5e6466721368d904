"""Inverse dynamics of a measured gait trial with Lagrange's prescription.

Route (issue 6):

1. The OpenSim model's segments become our bodies (unit quaternions, so no Euler
   singularity). Every joint's six relative directions are written at velocity level
   from the bodies' angular velocities and point velocities: ``s_i' = g^i . R_F^T
   (omega_C - omega_P)`` for the three rotation axes (dual Euler basis of the joint,
   paper eq. 11) and ``s' = A^-1 R_F^T (v_M - v_F - omega_P x (x_M - x_F))`` for the
   translations. A direction with a constant function, a direction coupled to a
   coordinate by a spline (gait2354 knee translations) and a *locked* coordinate
   become named constraints of the core (``<joint>.<axis>``, ``<joint>.<coordinate>``);
   each free coordinate becomes an actuator input whose load pair has power
   ``tau q'`` (a torque along ``g^i`` or a force along the dual translation axis).
2. The coordinates are filtered as OpenSim's ID tool does (pad by reflection, 3rd-order
   Butterworth run forward and backward, i.e. zero phase, at 6 Hz; then interpolating
   quintic splines, differentiated twice) and the bodies' ``q, u, u'`` follow from
   forward kinematics with automatic differentiation.
3. Each force plate is given to the foot standing on it (centre of pressure against
   the feet found from the kinematics), applied to that foot's hindfoot body.
4. ``G^T lambda + B tau = M u' - f`` (the Newton-Euler balances, paper eq. 13) is
   solved at every sample; joint loads follow from Lagrange's prescription (eq. 26) and
   the generalized force of every OpenSim coordinate from ``Phi = lambda A`` with
   ``A = G dU/dpdot`` (eqs. 38-41) plus the inputs: for a locked coordinate
   ``Phi = lambda`` exactly (eq. 44).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.interpolate import make_interp_spline

from .equations import SystemEquations
from .errors import OcpConstraintsError
from .model import Model
from .opensim_io import DataFileError, Plate, Table, grf_plates, read_grf, read_motion
from .osim_model import OsimJoint, OsimModel, OsimModelError, axis_rotation, load_osim
from .rotations import quaternion_from_rotation

CONTACT_THRESHOLD = 20.0   # N, vertical force above which a plate is loaded
FOOT_TOLERANCE = 0.25      # m, largest horizontal distance from a centre of pressure to its foot


class GaitError(OcpConstraintsError, ValueError):
    """A trial cannot be processed: inconsistent files, unknown coordinates, no foot on a plate."""


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
    from .constraints import Joint

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
        ev = np.linalg.eigvalsh(b.inertia)
        if ev.min() >= 0 and ev.sum() - 2 * ev.max() < -1e-12 * ev.max():
            # OpenSim accepts inertias that break the triangle inequality (JW 'toes'); so do
            # we here, to reproduce its results, but we say so.
            body = model.add_body(b.name, b.mass, np.diag([ev.max()] * 3), rotation="quaternion")
            body.inertia = b.inertia
            model.warnings.append(f"body '{b.name}': inertia {np.diag(b.inertia).tolist()} breaks the triangle "
                                  "inequality (not a physical rigid body); used as given, as OpenSim does")
        else:
            model.add_body(b.name, b.mass, b.inertia, rotation="quaternion")
    return model, {name: _add_joint(model, osim, osim.joints[name]) for name in osim.order}


# -- 2. coordinates: OpenSim's filter and spline ------------------------------------------------

def _opensim_iir(y: np.ndarray, dt: float, fc: float) -> np.ndarray:
    """OpenSim ``Signal::LowpassIIR``: 3rd-order Butterworth, forward then backward (zero phase)."""
    fs = 1.0 / dt
    if fc >= 0.5 * fs:
        fc = 0.49 * fs
    wa = np.tan(2 * np.pi * fc * dt / 2.0)
    wa2, wa3 = wa * wa, wa ** 3
    den = (wa + 1) * (wa2 + wa + 1.0)
    a = np.array([wa3, 3 * wa3, 3 * wa3, wa3]) / den
    b = np.array([1.0, (3 * wa3 + 2 * wa2 - 2 * wa - 3) / den, (3 * wa3 - 2 * wa2 - 2 * wa + 3) / den,
                  (wa - 1) * (wa2 - wa + 1) / den])

    def once(x):
        out = np.array(x, dtype=float)
        for i in range(3, len(x)):
            out[i] = (a[0] * x[i] + a[1] * x[i - 1] + a[2] * x[i - 2] + a[3] * x[i - 3]
                      - b[1] * out[i - 1] - b[2] * out[i - 2] - b[3] * out[i - 3])
        return out

    return once(once(y)[::-1])[::-1]


def _pad(x: np.ndarray, n: int) -> np.ndarray:
    """OpenSim ``Signal::Pad``: reflect and negate about both end values."""
    head = 2 * x[0] - x[n:0:-1]
    tail = 2 * x[-1] - x[-2:-n - 2:-1]
    return np.concatenate([head, x, tail])


@dataclass
class CoordinateSplines:
    """Filtered coordinates as quintic splines: values, rates and accelerations at any time."""

    names: list[str]
    splines: object
    t_range: tuple[float, float]

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, float))
        return tuple(np.asarray(self.splines(t, k)) for k in range(3))


def filter_coordinates(table: Table, names: list[str], cutoff: float | None = 6.0) -> CoordinateSplines:
    """Coordinates of ``table`` low-passed and splined as OpenSim's InverseDynamicsTool does.

    Pad each column by half its length (odd reflection), resample at the smallest step
    if the sampling is not uniform, 3rd-order Butterworth forward and backward at
    ``cutoff`` Hz (None: no filter), then interpolating quintic splines.
    """
    t = table.time
    Y = np.column_stack([table.column(n) for n in names])
    if cutoff is not None:
        n = len(t) // 2
        tp = _pad(t, n)
        Yp = np.column_stack([_pad(Y[:, k], n) for k in range(Y.shape[1])])
        dt = float(np.min(np.diff(tp)))
        if (tp[-1] - tp[0]) / (len(tp) - 1) - dt > np.finfo(float).eps:
            tn = tp[0] + dt * np.arange(int(np.floor((tp[-1] - tp[0]) / dt + 1e-9)) + 1)
            Yp = make_interp_spline(tp, Yp, k=5, axis=0)(tn)
            tp = tn
        Yf = np.column_stack([_opensim_iir(Yp[:, k], dt, cutoff) for k in range(Y.shape[1])])
        t, Y = tp, Yf
    return CoordinateSplines(names, make_interp_spline(t, Y, k=5, axis=0), (table.time[0], table.time[-1]))


# -- 3. legs, feet and force plates ----------------------------------------------------------------

@dataclass
class Leg:
    side: str
    hip: str
    chain: list[str]

    @property
    def foot(self) -> str:
        return self.chain[-2]


def find_legs(osim: OsimModel) -> dict[str, Leg]:
    """The two legs: subtrees hanging from the pelvis, side from the hip's z (+z is right)."""
    root = osim.outboard(osim.joints[osim.order[0]])
    legs = {}
    for name in osim.order:
        j = osim.joints[name]
        if osim.inboard(j) != root:
            continue
        chain = [osim.outboard(j)]
        while True:
            kids = [osim.outboard(k) for k in (osim.joints[n] for n in osim.order) if osim.inboard(k) == chain[-1]]
            if not kids:
                break
            chain.append(max(kids, key=lambda b: (_depth(osim, b), osim.bodies[b].mass)))
        fr = j.parent if not j.reversed else j.child
        if len(chain) < 4 or abs(fr.p[2]) < 1e-3:
            continue
        side = "right" if fr.p[2] > 0 else "left"
        if side not in legs or len(chain) > len(legs[side].chain):
            legs[side] = Leg(side, name, chain)
    if set(legs) != {"left", "right"}:
        raise GaitError(f"{osim.path}: could not find a left and a right leg below '{root}'")
    return legs


def _depth(osim: OsimModel, body: str) -> int:
    kids = [osim.outboard(osim.joints[n]) for n in osim.order if osim.inboard(osim.joints[n]) == body]
    return 1 + max((_depth(osim, k) for k in kids), default=0)


def assign_plates(plates: list[Plate], t_grf: np.ndarray, feet: dict[str, tuple[np.ndarray, np.ndarray]],
                  up: np.ndarray, where: str) -> dict[str, str]:
    """Which foot stands on each loaded plate: ``plate -> side``.

    ``feet[side]`` holds the heel (hindfoot origin) and toe positions (samples x 3, at
    ``t_grf``); the plate goes to the foot whose heel-toe segment is nearest (horizontal
    distance, median over the loaded samples) to the centre of pressure.
    """
    out = {}
    for pl in plates:
        loaded = pl.force @ up > CONTACT_THRESHOLD
        if not loaded.any():
            continue
        cop = pl.point[loaded]
        dist = {}
        for side, (heel, toe) in feet.items():
            h, tt = heel[loaded], toe[loaded]
            d = tt - h
            d -= np.outer(d @ up, up)
            w = cop - h
            w -= np.outer(w @ up, up)
            s = np.clip(np.einsum("ij,ij->i", w, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-12), 0, 1)
            dist[side] = float(np.median(np.linalg.norm(w - s[:, None] * d, axis=1)))
        side = min(dist, key=dist.get)
        if dist[side] > FOOT_TOLERANCE:
            raise GaitError(f"{where}: {pl.name} is loaded ({int(loaded.sum())} samples) but no foot stands on it: "
                            f"the nearest foot ({side}) is {dist[side]:.2f} m from its centre of pressure")
        out[pl.name] = side
    return out


# -- 4. the trial ---------------------------------------------------------------------------------

@dataclass
class GaitResult:
    """Inverse dynamics of a trial.

    ``generalized_forces`` (samples x coordinates) are in OpenSim's sense (N m for
    rotational, N for translational coordinates): inputs for free coordinates plus
    ``sum_k lambda_k A_k`` (eqs. 38-41) for every coordinate. ``loads`` holds DESIGN.md's
    columns (``<constraint>.lambda``, ``<joint>@<body>.F_x`` ... in the ground frame).
    """

    t: np.ndarray
    coordinate_names: list[str]
    generalized_forces: np.ndarray
    lam: np.ndarray
    tau: np.ndarray
    residual: np.ndarray
    loads: dict[str, np.ndarray]
    joints: dict[str, JointInfo]
    legs: dict[str, Leg]
    plates: dict[str, str]
    timings: dict[str, float]
    warnings: list[str]
    osim: OsimModel
    model: Model
    eqs: SystemEquations
    states: dict[str, np.ndarray]

    def generalized_force(self, coordinate: str) -> np.ndarray:
        if coordinate not in self.coordinate_names:
            raise GaitError(f"no coordinate '{coordinate}' (coordinates: {', '.join(self.coordinate_names)})")
        return self.generalized_forces[:, self.coordinate_names.index(coordinate)]

    def leg_joints(self, side: str) -> list[str]:
        """Names of the joints of one leg (hip to toes), in tree order."""
        bodies = set(self.osim.subtree(self.legs[side].chain[0]))
        return [n for n in self.osim.order if self.osim.outboard(self.osim.joints[n]) in bodies]


def _check_columns(osim: OsimModel, motion: Table) -> list[str]:
    names = osim.coordinate_names
    unknown = [n for n in motion.columns if n not in osim.coordinates]
    if unknown:
        raise GaitError(f"{motion.path}: coordinate(s) {unknown} are not in the model {osim.path}")
    missing = [n for n in names if n not in motion.columns]
    if missing:
        raise GaitError(f"{motion.path}: missing column(s) for the model coordinate(s) {missing}")
    return names


def _window(motion: Table, grf: Table, start, end, times) -> np.ndarray:
    t0 = motion.time[0] if start is None else float(start)
    t1 = motion.time[-1] if end is None else float(end)
    dt = float(np.median(np.diff(motion.time)))
    if not (motion.time[0] - 1e-9 <= t0 < t1 <= motion.time[-1] + 1e-9):
        raise GaitError(f"{motion.path}: covers {motion.time[0]:g} ... {motion.time[-1]:g} s; the requested "
                        f"window {t0:g} ... {t1:g} s is not inside it")
    if times is None:
        times = motion.time[(motion.time >= t0 - 1e-9) & (motion.time <= t1 + 1e-9)]
    times = np.asarray(times, float)
    if times.min() < motion.time[0] - 1.01 * dt or times.max() > motion.time[-1] + 1.01 * dt:
        raise GaitError(f"{motion.path}: times {times.min():g} ... {times.max():g} s fall outside the motion")
    if times.min() < grf.time[0] - 1e-9 or times.max() > grf.time[-1] + 1e-9:
        raise GaitError(f"time ranges do not match: {grf.path} covers {grf.time[0]:g} ... {grf.time[-1]:g} s "
                        f"but the motion window {motion.path} needs {times.min():g} ... {times.max():g} s")
    return times


def _inverse_function(eqs: SystemEquations) -> ca.Function:
    """``(q, u, udot, fext) -> (A, b)`` with ``A [lambda; tau] = b`` (Newton-Euler, eq. 13)."""
    udot, fext = ca.SX.sym("udot", eqs.nu), ca.SX.sym("fext", eqs.nu)
    f0 = ca.substitute(eqs.forces, eqs.inputs, ca.SX.zeros(eqs.inputs.shape))
    A = ca.horzcat(eqs.G.T, ca.jacobian(eqs.forces, eqs.inputs))
    b = eqs.mass_matrix @ udot - f0 - fext
    return ca.Function("gait_id", [eqs.q, eqs.u, udot, fext], [A, b, eqs.G])


def run_inverse_dynamics(model_path, motion_path, grf_path, start: float | None = None, end: float | None = None,
                         cutoff: float | None = 6.0, times=None) -> GaitResult:
    """Inverse dynamics of a trial from files to joint loads (see the module docstring).

    Parameters
    ----------
    model_path, motion_path, grf_path
        ``.osim`` model, coordinates (IK output, any format of :mod:`opensim_io`),
        ground reaction forces (one or more plates).
    start, end
        Window (s); default the whole motion.
    cutoff
        Low-pass cutoff for the coordinates (Hz), OpenSim's default 6; None: no filter.
    times
        Sample times (s) to evaluate at (default: the motion's samples in the window).
    """
    clock = {"start": time.perf_counter()}
    osim = load_osim(model_path)
    trans = [n for n, c in osim.coordinates.items() if not c.rotational]
    motion = read_motion(motion_path, translational=trans)
    grf = read_grf(grf_path)
    names = _check_columns(osim, motion)
    t = _window(motion, grf, start, end, times)
    plates = grf_plates(grf)
    clock["read"] = time.perf_counter()
    model, joints = constraint_model(osim)
    eqs = SystemEquations(model)
    legs = find_legs(osim)
    clock["model"] = time.perf_counter()

    splines = filter_coordinates(motion, names, cutoff)
    P, Pd, Pdd = splines(t)
    bodies = list(model.bodies)
    N, nb = len(t), len(bodies)
    R, xbar, vbar, w, abar, alpha, J = (np.asarray(x) for x in
                                        osim.kinematics_function(bodies).map(N)(P.T, Pd.T, Pdd.T))
    q = np.zeros((N, 7 * nb))
    u = np.zeros((N, 6 * nb))
    ud = np.zeros((N, 6 * nb))
    for k in range(nb):
        q[:, 7 * k:7 * k + 3] = xbar[3 * k:3 * k + 3].T
        for n in range(N):
            q[n, 7 * k + 3:7 * k + 7] = quaternion_from_rotation(R[9 * k:9 * k + 9, n].reshape(3, 3, order="F"))
        u[:, 6 * k:6 * k + 3], u[:, 6 * k + 3:6 * k + 6] = vbar[3 * k:3 * k + 3].T, w[3 * k:3 * k + 3].T
        ud[:, 6 * k:6 * k + 3], ud[:, 6 * k + 3:6 * k + 6] = abar[3 * k:3 * k + 3].T, alpha[3 * k:3 * k + 3].T
    clock["kinematics"] = time.perf_counter()

    # force plates -> feet
    up = -np.asarray(osim.gravity) / np.linalg.norm(osim.gravity)
    in_window = (grf.time >= t.min() - 1e-9) & (grf.time <= t.max() + 1e-9)
    tg = grf.time[in_window]
    pts = ca.SX.sym("p", len(names))
    X = osim.poses({n: pts[i] for i, n in enumerate(names)})
    foot_fn = ca.Function("feet", [pts], [ca.vertcat(*[X[legs[s].chain[c]][1] for s in legs for c in (-2, -1)])])
    Pg = splines(tg)[0]
    fp = np.asarray(foot_fn.map(len(tg))(Pg.T)).T
    feet = {s: (fp[:, 6 * i:6 * i + 3], fp[:, 6 * i + 3:6 * i + 6]) for i, s in enumerate(legs)}
    window_plates = [Plate(p.name, p.force[in_window], p.point[in_window], p.torque[in_window], p.columns) for p in plates]
    assigned = assign_plates(window_plates, tg, feet, up, str(grf.path))
    fext = np.zeros((N, 6 * nb))
    for pl in plates:
        if pl.name not in assigned:
            continue
        k = bodies.index(legs[assigned[pl.name]].foot)
        F = np.column_stack([np.interp(t, grf.time, pl.force[:, i]) for i in range(3)])
        cop = np.column_stack([np.interp(t, grf.time, pl.point[:, i]) for i in range(3)])
        T = np.column_stack([np.interp(t, grf.time, pl.torque[:, i]) for i in range(3)])
        fext[:, 6 * k:6 * k + 3] += F
        fext[:, 6 * k + 3:6 * k + 6] += np.cross(cop - q[:, 7 * k:7 * k + 3], F) + T
    clock["grf"] = time.perf_counter()

    A, b, G = (np.asarray(x) for x in _inverse_function(eqs).map(N)(q.T, u.T, ud.T, fext.T))
    n_un = A.shape[1] // N
    A = np.stack([A[:, n * n_un:(n + 1) * n_un] for n in range(N)])
    cond = np.linalg.cond(A[0])
    if not np.isfinite(cond) or cond > 1e12:
        raise GaitError(f"{model_path}: multipliers and inputs are not determined (condition number {cond:.3g})")
    x = np.linalg.solve(A, b.T[:, :, None])[:, :, 0]
    residual = np.linalg.norm(np.einsum("nij,nj->ni", A, x) - b.T, axis=1)
    lam, tau = x[:, :eqs.nc], x[:, eqs.nc:]
    # generalized forces per OpenSim coordinate: inputs + Phi = lambda A, A = G dU/dpdot (eqs. 38-41)
    Gs = np.stack([G[:, n * eqs.nu:(n + 1) * eqs.nu] for n in range(N)])
    Js = np.stack([J[:, n * len(names):(n + 1) * len(names)] for n in range(N)])
    gen = np.einsum("nk,nkc->nc", lam, Gs @ Js)
    inputs = list(model.inputs)
    for i, name in enumerate(inputs):
        gen[:, names.index(name)] += tau[:, i]
    clock["solve"] = time.perf_counter()
    loads = joint_load_columns(eqs, q, u, t, lam)
    clock["loads"] = time.perf_counter()
    steps = ["read", "model", "kinematics", "grf", "solve", "loads"]
    prev, timings = clock["start"], {}
    for s_ in steps:
        timings[s_] = clock[s_] - prev
        prev = clock[s_]
    timings["total"] = clock["loads"] - clock["start"]
    return GaitResult(t, names, gen, lam, tau, residual, loads, joints, legs, assigned, timings,
                      list(getattr(model, "warnings", [])), osim, model, eqs,
                      {"q": q, "u": u, "udot": ud, "p": P, "pdot": Pd, "pddot": Pdd, "J": Js, "fext": fext})


def joint_load_columns(eqs: SystemEquations, q, u, t, lam) -> dict[str, np.ndarray]:
    """DESIGN.md load columns: ``<constraint>.lambda``, per joint channel F, M, point, power."""
    out = {f"{n}.lambda": lam[:, i] for i, n in enumerate(eqs.constraint_names)}
    L = np.asarray(eqs.loads_function.map(len(t))(q.T, u.T, t, lam.T)).T
    for c, ch in enumerate(eqs.load_channels):
        block = L[:, 10 * c:10 * c + 10]
        for i, a in enumerate("xyz"):
            out[f"{ch.prefix}.F_{a}"] = block[:, i]
            out[f"{ch.prefix}.M_{a}"] = block[:, 3 + i]
            out[f"{ch.prefix}.point_{a}"] = block[:, 6 + i]
        out[f"{ch.prefix}.power"] = block[:, 9]
    return out


def compare(result: GaitResult, reference: Table, coordinates: list[str]) -> dict[str, dict[str, float]]:
    """RMS difference from OpenSim's generalized forces (``<coord>_moment`` / ``_force``).

    The reference is interpolated to the result's times. Returns per coordinate
    ``rms`` (N m or N), ``peak`` (largest magnitude of the reference) and ``percent``.
    """
    out = {}
    for c in coordinates:
        col = next((n for n in (f"{c}_moment", f"{c}_force") if n in reference.columns), None)
        if col is None:
            raise DataFileError(reference.path, f"has no column '{c}_moment' or '{c}_force'")
        ref = np.interp(result.t, reference.time, reference.columns[col])
        diff = result.generalized_force(c) - ref
        rms, peak = float(np.sqrt(np.mean(diff ** 2))), float(np.max(np.abs(ref)))
        out[c] = {"rms": rms, "peak": peak, "percent": 100 * rms / peak if peak > 0 else float("nan")}
    return out


# -- 5. command line ------------------------------------------------------------------------------

def add_gait_parser(subparsers) -> None:
    """``gait --model M.osim --motion IK --grf GRF [--side right] [--start T0 --end T1] --out DIR``."""
    g = subparsers.add_parser("gait", help="inverse dynamics of a gait trial: joint loads by Lagrange's prescription")
    g.add_argument("--model", required=True, help="OpenSim model (.osim, 4.x format)")
    g.add_argument("--motion", required=True, help="joint coordinates (IK .mot/.sto, JW .csv/.mat)")
    g.add_argument("--grf", required=True, help="ground reaction forces (.mot/.sto/.csv/.mat, any number of plates)")
    g.add_argument("--side", choices=("right", "left"), default="right", help="leg whose joints are reported")
    g.add_argument("--start", type=float, default=None, help="first time [s] (default: start of the motion)")
    g.add_argument("--end", type=float, default=None, help="last time [s] (default: end of the motion)")
    g.add_argument("--cutoff", type=float, default=6.0, help="low-pass cutoff of the coordinates [Hz] (default 6)")
    g.add_argument("--out", required=True, help="folder for summary.json, loads.csv and plots")
    g.add_argument("--no-plots", action="store_true", help="write no PNG plots")
    g.set_defaults(handler=cli_gait)


def write_gait_results(result: GaitResult, out, side: str = "right", plots: bool = True, inputs: dict | None = None) -> dict:
    """``summary.json``, ``loads.csv`` (DESIGN.md names plus ``<coordinate>_moment/_force``) and plots."""
    from .results import prepare_output_folder, software_versions, write_csv, write_json

    folder = prepare_output_folder(out)
    leg = result.leg_joints(side)
    cols = {}
    for i, c in enumerate(result.coordinate_names):
        suffix = "_moment" if result.osim.coordinates[c].rotational else "_force"
        cols[f"{c}{suffix}"] = result.generalized_forces[:, i]
    cols.update(result.loads)
    write_csv(folder / "loads.csv", result.t, cols)
    summary = {
        "task": "gait inverse dynamics", "model": result.osim.path, "inputs": inputs or {},
        "side": side, "samples": len(result.t), "t_start": float(result.t[0]), "t_end": float(result.t[-1]),
        "filter": {"coordinates": "OpenSim ID tool: reflect-pad, 3rd-order Butterworth forward+backward, quintic splines"},
        "plates": result.plates, "feet": {s: l.foot for s, l in result.legs.items()},
        "leg_joints": {j: {"constraints": result.joints[j].constraints, "inputs": result.joints[j].inputs,
                           "parent": result.joints[j].parent, "child": result.joints[j].child} for j in leg},
        "n_constraints": len(result.eqs.constraint_names), "n_inputs": len(result.model.inputs),
        "max_equation_residual": float(result.residual.max()),
        "peak_generalized_forces": {c: float(np.max(np.abs(result.generalized_force(c))))
                                    for j in leg for c in result.osim.joints[j].coordinates},
        "wall_time": result.timings, "warnings": result.warnings, "software": software_versions(),
    }
    write_json(folder / "summary.json", summary)
    if plots:
        summary["plots"] = _plots(result, folder, leg)
    return summary


def _plots(result: GaitResult, folder: Path, leg: list[str]) -> list[str]:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .results import write_atomic

    written = []
    for j in leg:
        coords = result.osim.joints[j].coordinates
        fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
        for c in coords:
            axes[0].plot(result.t, result.generalized_force(c), label=c)
        axes[0].set(ylabel="generalized force [N m or N]", title=f"{j}: generalized forces, load on the child at its point")
        prefix = next((p for p in (f"{j}@{result.joints[j].child}", j) if f"{p}.F_x" in result.loads), None)
        if prefix:
            for a in "xyz":
                axes[1].plot(result.t, result.loads[f"{prefix}.F_{a}"], label=f"F_{a}")
                axes[2].plot(result.t, result.loads[f"{prefix}.M_{a}"], label=f"M_{a}")
        axes[1].set(ylabel="constraint force [N]")
        axes[2].set(xlabel="t [s]", ylabel="constraint moment [N m]")
        for ax in axes:
            ax.grid(alpha=0.3)
            if ax.lines:
                ax.legend(fontsize=7)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100)
        plt.close(fig)
        write_atomic(folder / f"gait_{j}.png", buf.getvalue())
        written.append(f"gait_{j}.png")
    return written


def cli_gait(args) -> int:
    """Run ``gait``; errors in the input print one line and return 2."""
    import sys

    try:
        result = run_inverse_dynamics(args.model, args.motion, args.grf, args.start, args.end,
                                      args.cutoff if args.cutoff and args.cutoff > 0 else None)
        summary = write_gait_results(result, args.out, args.side, plots=not getattr(args, "no_plots", False),
                                     inputs={"model": args.model, "motion": args.motion, "grf": args.grf})
    except OcpConstraintsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"gait: {summary['samples']} samples {summary['t_start']:g} ... {summary['t_end']:g} s, "
          f"plates {summary['plates']}, inverse dynamics in {result.timings['total']:.2f} s; results in {args.out}")
    return 0
