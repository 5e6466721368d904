"""Property test: the identities of Lagrange's prescription on >= 1,000 random multibody systems (300 in the suite).

What is randomized (numpy generator, seed printed on failure):

* per *topology* (a few dozen, each built once with CasADi): a tree of 1-4 bodies, each
  hung from the ground or an earlier body by a joint drawn from the library
  (ball-and-socket, revolute, universal, cylindrical, prismatic, planar, weld, point on a
  line); masses 0.5-2 kg, inertia tensors with random principal moments (positive,
  triangle inequality) and random principal axes; rotation parameters quaternion, 3-2-1 or
  3-1-3 angles; random poses at which the joint geometry (points, axes, relative rotations)
  is assembled; sometimes a time-varying drive ``g^i . omega = Omega(t)`` or a moving
  sliding contact ``n . v_P = c cos(t)`` (constraints with ``e != 0``, so the power
  identity is not trivially zero); per body an applied force at a random point and an
  applied torque, entering as model inputs;
* per *draw* (many per topology; each (topology, draw) counts as one system): the
  configuration (assembly perturbed by 0.05 in every coordinate, then projected onto the
  position forms by :func:`project_positions`), speeds (:func:`consistent_state` plus a
  random admissible motion from the null space of the constraint Jacobian), the time, and
  the applied loads (the input values).

Per system, with the multipliers of the forward dynamics (the KKT solve used by ``simulate``):

* power identity (eq. 27): per joint, ``sum (F_c . v_C + M_c . omega) + sum lambda_k e_k = 0``,
  with ``v_C`` computed here from the speeds and the reported point;
* equipollence (eqs. 32-33): a twin model with every constraint rewritten at another
  material point of each body (``v_C -> v_A + omega x (x_C - x_A)``) has the same constraint
  Jacobian and ``e``, its own forward dynamics gives the same multipliers and accelerations
  (two solves of the KKT matrix ``K``: to 1e-10, or to ``10 cond(K) eps`` where that is larger),
  and its loads are the same force at ``X_A`` with the moment ``M_A = M_C + (x_C - x_A) x F``;
* ``Phi = lambda A`` (eqs. 38-41): ``eqs.generalized_constraint_forces`` equals ``lambda_k A_k``
  with ``A = d(pi)/d(qdot)`` obtained here through the position Jacobians of the points and
  ``omega = axial(Qdot Q^T)``, and the reported loads' generalized force
  ``F . d(x_C)/dq + M . d(omega)/d(qdot)`` equals ``sum_k Phi_k``;
* Newton's third law for every two-body joint: equal and opposite forces and moments about a
  common point;

all to 1e-10 relative (to the size of the terms compared; multipliers normwise). Every
returned number is finite, or the library raised one of its errors (redundant constraints,
a singular Euler configuration, ...), which is counted and printed (``pytest -s``) with the
mix of joints and the number of ill-conditioned systems (cond of the KKT matrix > 1e5, e.g.
a drive nearly normal to the axis it should turn). ``OCP_PROPERTY_SYSTEMS=10000`` runs more
(the default 1,000 take about 18 s of CPU; 10,000 about 3 min).
"""
from __future__ import annotations

import math
import os

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ocp_constraints import joints
from ocp_constraints.errors import OcpConstraintsError
from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.mechanics.model import Model
from ocp_constraints.mechanics.state import consistent_state, project_positions

# The suite checks the first 300 systems; the slow check (python -m pytest -m slow) all 1,000, or as many as asked.
N_SYSTEMS = int(os.environ.get("OCP_PROPERTY_SYSTEMS", "1000"))
IN_SUITE = min(N_SYSTEMS, 300)
DRAWS = 40
RTOL = 1e-10
SEED = 20260412
KKT_COND_LIMIT = 1e5      # counted and reported (ill-conditioned systems)
KINDS = ["ball_and_socket", "revolute", "universal", "cylindrical", "prismatic", "planar", "weld", "point_on_line"]
FREE_ROTATION = {"ball_and_socket", "revolute", "universal", "cylindrical", "planar", "point_on_line"}


def unit(v):
    return v / np.linalg.norm(v)


def params_of(R, rotation):
    r = Rotation.from_matrix(R)
    if rotation == "quaternion":
        x, y, z, w = r.as_quat()
        return np.array([w, x, y, z])
    return r.as_euler({"321": "ZYX", "313": "ZXZ"}[rotation])


def random_pose(rng, rotation):
    """A random rotation away from the Euler singularity (|sin| or |cos| of the 2nd angle > 0.3)."""
    while True:
        R = Rotation.random(random_state=rng).as_matrix()
        if rotation == "quaternion":
            return R
        a2 = params_of(R, rotation)[1]
        if (abs(math.sin(a2)) if rotation == "313" else abs(math.cos(a2))) > 0.3:
            return R


def random_inertia(rng):
    while True:
        p = rng.uniform(0.02, 0.3, 3)
        if p.sum() - 2 * p.max() > 0.005:
            R = Rotation.random(random_state=rng).as_matrix()
            J = R @ np.diag(p) @ R.T
            return 0.5 * (J + J.T)


def cross(a, b):
    """``a x b`` for 3-vectors (numpy's ``cross`` costs ~20 us a call, which adds up here)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def axial(W):
    return 0.5 * ca.vertcat(W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1])


class Topology:
    """One random tree of bodies and joints, its equations, and its twin written at other points."""

    def __init__(self, rng: np.random.Generator, index: int):
        n = int(rng.choice([1, 2, 3, 4], p=[0.1, 0.2, 0.3, 0.4]))     # more bodies: more two-body joints
        m = Model(f"random{index}", gravity=tuple(rng.normal(size=3) * 5))
        poses, kinds, alt = [], [], {}
        self.kinds_two = []
        for i in range(n):
            rotation = str(rng.choice(["quaternion", "321", "313"]))
            R = random_pose(rng, rotation)
            x = rng.normal(size=3)
            b = m.add_body(f"b{i}", float(rng.uniform(0.5, 2.0)), random_inertia(rng), rotation=rotation)
            poses.append((x, R, rotation))
            parent = int(rng.integers(-1, i))           # -1: the ground
            kind = str(rng.choice(KINDS))
            kinds.append(kind)
            self.kinds_two.append((kind, parent >= 0))
            nvec = unit(rng.normal(size=3))
            avec = unit(np.cross(nvec, rng.normal(size=3)))
            bvec = np.cross(nvec, avec)
            xJ = x + rng.normal(size=3) * 0.5
            shift = {"cylindrical": nvec, "prismatic": nvec, "point_on_line": nvec, "planar": avec}.get(kind, 0 * nvec)
            xC1 = xJ + rng.uniform(0.1, 0.4) * shift
            P = b.point(f"j{i}", R.T @ (xC1 - x))
            if parent < 0:
                R2, other, anchor = np.eye(3), None, xJ
            else:
                x2, R2, _ = poses[parent]
                pb = m.body(f"b{parent}")
                other, anchor = pb.point(f"j{i}", R2.T @ (xJ - x2)), None
                alt[(f"j{i}", pb.name)] = pb.point(f"alt_j{i}", rng.normal(size=3) * 0.5)
            alt[(f"j{i}", b.name)] = b.point(f"alt_j{i}", rng.normal(size=3) * 0.5)
            self._joint(kind, m, f"j{i}", P, other, anchor, R2, R, nvec, avec, bvec)
            # time-varying constraints (e != 0): a drive, a moving sliding contact
            if rotation != "quaternion" and kind in FREE_ROTATION and rng.random() < 0.4:
                w0, w1 = rng.normal(size=2)
                joints.driven_axis(m, f"drive{i}", b, w0 + w1 * ca.sin(m.t), index=int(rng.integers(1, 4)))
                alt[(f"drive{i}", b.name)] = b.point(f"alt_drive{i}", rng.normal(size=3) * 0.5)
            if kind not in ("weld", "prismatic") and rng.random() < 0.3:
                S = b.point(f"s{i}", rng.normal(size=3) * 0.5)
                joints.sliding_contact(m, f"slide{i}", S, normal=rng.normal(size=3),
                                       rate=float(rng.normal()) * ca.cos(m.t), height=None)
                alt[(f"slide{i}", b.name)] = b.point(f"alt_slide{i}", rng.normal(size=3) * 0.5)
            f = ca.vertcat(*[m.add_input(f"f{i}{c}") for c in "xyz"])
            tau = ca.vertcat(*[m.add_input(f"tau{i}{c}") for c in "xyz"])
            m.add_force(f"push{i}", b.point(f"load{i}", rng.normal(size=3) * 0.5), f)
            m.add_torque(f"twist{i}", b, tau)
        self.model, self.kinds, self.alt = m, kinds, alt
        self.q0 = np.concatenate([np.concatenate([x, params_of(R, rot)]) for x, R, rot in poses])
        starts = np.cumsum([0] + [b.q.numel() for b in m.bodies.values()])
        self.quaternions = [slice(k + 3, k + 7) for k, b in zip(starts, m.bodies.values()) if b.q.numel() == 7]
        self.eqs = SystemEquations(m)
        self.twin = SystemEquations(self._twin())
        self._independent_functions()

    @staticmethod
    def _joint(kind, m, name, P, other, anchor, R2, R1, n, a, b):
        if kind == "ball_and_socket":
            joints.ball_and_socket(m, name, P, other, anchor=anchor)
        elif kind == "revolute":
            joints.revolute(m, name, P, axis=R2.T @ n, anchor=anchor, body_axis=R1.T @ n, other=other)
        elif kind == "universal":
            joints.universal(m, name, P, other, axis=R2.T @ n, body_axis=R1.T @ a, anchor=anchor)
        elif kind == "cylindrical":
            joints.cylindrical(m, name, P, other, axis=R2.T @ n, body_axis=R1.T @ n, anchor=anchor)
        elif kind == "prismatic":
            joints.prismatic(m, name, P, other, axis=R2.T @ n, anchor=anchor, relative_rotation=R2.T @ R1)
        elif kind == "planar":
            joints.planar(m, name, P, other, normal=R2.T @ n, body_normal=R1.T @ n, anchor=anchor)
        elif kind == "weld":
            joints.weld(m, name, P, other, anchor=anchor, relative_rotation=R2.T @ R1)
        else:
            joints.point_on_line(m, name, P, other, axis=R2.T @ n, anchor=anchor)

    def _twin(self) -> Model:
        """The same bodies and loads; every constraint rewritten at another material point (eq. 32)."""
        m = self.model
        m2 = Model(m.name + "_twin", gravity=m.gravity)
        m2.t, m2.bodies, m2.forces, m2.torques, m2.inputs = m.t, m.bodies, m.forces, m.torques, m.inputs
        for j in m.joints.values():
            for c in j.constraints:
                sym, val = [], []
                for bname, P in j.points.items():
                    A = self.alt[(j.name, bname)]
                    sym.append(P.v)
                    val.append(A.v + ca.cross(P.body.omega, P.position - A.position))
                expr = ca.substitute(c.expression, ca.vertcat(*sym), ca.vertcat(*val))
                m2.add_constraint(c.name, expr, joint=j.name, position=c.position,
                                  point=self.alt[(j.name, c.shares[0].body.name)])
        return m2

    def _independent_functions(self) -> None:
        """``A = d(pi)/d(qdot)`` through position Jacobians and ``omega = axial(Qdot Q^T)``; per load
        channel the Jacobians ``d(x_C)/dq`` and ``d(omega)/d(qdot)``; positions of the points."""
        eqs, m = self.eqs, self.model
        q, qd = eqs.q, ca.SX.sym("qd", eqs.nq)
        sym, val, omega = [], [], {}
        for b in eqs.bodies:
            Qdot = ca.reshape(ca.jacobian(ca.vec(b.Q), q) @ qd, 3, 3)
            omega[b.name] = axial(Qdot @ b.Q.T)
            sym.append(b.omega)
            val.append(omega[b.name])
            for p in b.points.values():
                sym.append(p.v)
                val.append(ca.jacobian(p.position, q) @ qd)
        pi = ca.substitute(ca.vertcat(*[c.expression for c in eqs.constraints]), ca.vertcat(*sym), ca.vertcat(*val))
        self.A = ca.Function("A_indep", [q, eqs.t], [ca.jacobian(pi, qd)])
        jac, pts = [], []
        for ch in eqs.load_channels:
            j, body = m.joints[ch.joint], m.bodies[ch.body]
            pt = j.points[body.name]
            jac += [ca.jacobian(pt.position, q), ca.jacobian(omega[body.name], qd)]
            pts += [pt.position, self.alt[(ch.joint, body.name)].position]
        self.channel_jacobians = ca.Function("channel_jacobians", [q], jac)
        self.points = ca.Function("points", [q], [ca.horzcat(*pts)])


def channel_loads(eqs, q, u, t, lam):
    out = np.asarray(eqs.loads_function(q, u, t, lam)).ravel().reshape(-1, 10)
    return out[:, 0:3], out[:, 3:6], out[:, 6:9]


def close(a, b, scale) -> bool:
    return bool(np.max(np.abs(np.asarray(a) - np.asarray(b)), initial=0.0) <= RTOL * max(scale, 1e-300))


def check_system(top: Topology, rng: np.random.Generator) -> tuple[list[str], bool]:
    """One random state of ``top``; returns the identities that failed (empty if all hold) and whether
    the KKT matrix is ill-conditioned (cond > KKT_COND_LIMIT; counted, the checks are the same).

    Raises the library's error if the state is refused (redundant constraints, a singular
    Euler configuration, ...)."""
    eqs, twin = top.eqs, top.twin
    t = float(rng.uniform(0, 5))
    q = project_positions(eqs, top.q0 + 0.05 * rng.normal(size=eqs.nq), t)
    # project_positions makes quaternions unit *before* its Gauss-Newton steps, which leave
    # |q| = 1 + O(step^2) (1.002 here), and at a non-unit quaternion the library's
    # generalized_constraint_forces (through u = B(q) q') is off by |q|^2: make them unit again
    # (the position forms do not depend on the quaternion's norm).
    for sl in top.quaternions:
        q[sl] /= np.linalg.norm(q[sl])
    q, u = consistent_state(eqs, dict(zip(eqs.model.coordinate_names, q)), {}, t0=t)
    G, e = (np.asarray(x) for x in eqs.constraint_functions(q, u, t, np.zeros(eqs.inputs.numel()))[:2])
    Z = np.linalg.svd(G)[2][eqs.nc:].T      # full row rank (consistent_state checked redundancy)
    u = u + Z @ rng.normal(size=Z.shape[1])
    w = rng.normal(size=eqs.inputs.numel()) * 2.0
    udot, lam = (np.asarray(x).ravel() for x in eqs.forward_dynamics(q, u, t, w, np.zeros_like(w)))
    F, M, X = channel_loads(eqs, q, u, t, lam)
    Phi = eqs.generalized_constraint_forces(q, lam, t)
    failed = []
    values = [udot, lam, F, M, X, Phi]
    if not all(np.all(np.isfinite(v)) for v in values):
        return ["a non-finite number was returned without an error"], False
    e = e.ravel()
    chans = eqs.load_channels
    index = {c.name: k for k, c in enumerate(eqs.constraints)}
    speeds = {b.name: (u[6 * i:6 * i + 3], u[6 * i + 3:6 * i + 6]) for i, b in enumerate(eqs.bodies)}
    xbar = {b.name: q[i0:i0 + 3] for b, i0 in zip(eqs.bodies, np.cumsum([0] + [b.q.numel() for b in eqs.bodies]))}
    u_size = np.abs(u).max()
    # power identity per joint (eq. 27)
    for jname, j in eqs.model.joints.items():
        # scale: the size of the terms, |F| |u| (1 + |x_C - xbar|) + |M| |u| + |lambda e|, with |u| the largest
        # speed of the system (a joint's point may be at rest while its speed is a sum of large ones)
        power, scale = 0.0, 0.0
        for i, ch in enumerate(chans):
            if ch.joint == jname:
                vb, om = speeds[ch.body]
                v_C = vb + cross(om, X[i] - xbar[ch.body])
                power += F[i] @ v_C + M[i] @ om
                scale += u_size * (np.abs(F[i]).max() * (1 + np.abs(X[i] - xbar[ch.body]).max()) + np.abs(M[i]).max())
        for c in j.constraints:
            power += lam[index[c.name]] * e[index[c.name]]
            scale += abs(lam[index[c.name]] * e[index[c.name]])
        if not close(power, 0.0, scale):
            failed.append(f"power identity of joint '{jname}': residual {power:.3g} of terms of size {scale:.3g}")
    # Newton's third law, moments about the origin
    for jname in eqs.model.joints:
        rows = [i for i, ch in enumerate(chans) if ch.joint == jname]
        if len(rows) == 2:
            a, b = rows
            Fs, Ms = F[a] + F[b], M[a] + cross(X[a], F[a]) + M[b] + cross(X[b], F[b])
            scale = max(np.abs(F[a]).max(), np.abs(M[a]).max(), np.abs(cross(X[a], F[a])).max())
            if not (close(Fs, 0, scale) and close(Ms, 0, scale)):
                failed.append(f"third law at joint '{jname}': force sum {Fs}, moment sum {Ms}")
    # equipollence: the twin written at other material points (eqs. 32-33). Its constraints are the
    # same functions of the speeds, so the same multipliers solve it; the twin's loads for these
    # multipliers are the original ones moved to the other points (eq. 33).
    G2, e2 = (np.asarray(x) for x in twin.constraint_functions(q, u, t, w)[:2])
    if not (close(G2, G, np.abs(G).max()) and close(e2.ravel(), e, np.abs(e).max())):
        failed.append(f"equipollence: the twin's constraint Jacobian differs by {np.abs(G2 - G).max():.3g}")
    udot2, lam2 = (np.asarray(x).ravel() for x in twin.forward_dynamics(q, u, t, w, np.zeros_like(w)))
    Mm = np.asarray(eqs.mass_matrix_function(q))
    kkt_cond = np.linalg.cond(np.block([[Mm, -G.T], [G, np.zeros((eqs.nc, eqs.nc))]])) if eqs.nc else 1.0
    ill_conditioned = kkt_cond > KKT_COND_LIMIT
    # Two solves of (rounding-different copies of) K agree to ~cond(K) eps, normwise: to 1e-10 below
    # cond(K) = 4.5e4, to 10 cond(K) eps above (e.g. a drive nearly normal to the axis it turns).
    # Multipliers relative to the largest one; accelerations relative to their own size or to that
    # of the constraint loads' term M^-1 G^T lambda.
    tol = max(1.0, 10 * kkt_cond * np.finfo(float).eps / RTOL)
    a_scale = max(np.abs(udot).max(), np.abs(G.T @ lam).max() / np.diag(Mm).min())
    if not (close(lam2, lam, tol * np.abs(lam).max()) and close(udot2, udot, tol * a_scale)):
        failed.append(f"equipollence: multipliers differ by {np.abs(lam2 - lam).max():.3g}, accelerations "
                      f"by {np.abs(udot2 - udot).max():.3g} (cond(K) = {kkt_cond:.3g})")
    F2, M2, X2 = channel_loads(twin, q, u, t, lam)
    P = np.asarray(top.points(q)).T.reshape(-1, 2, 3)
    for i, ch in enumerate(chans):
        x_C, x_A = P[i]
        M_A = M[i] + cross(x_C - x_A, F[i])
        scale = max(np.abs(F[i]).max() * (1 + np.abs(x_C - x_A).max()), np.abs(M[i]).max())
        if not (close(X2[i], x_A, 1 + np.abs(x_A).max()) and close(F2[i], F[i], scale) and close(M2[i], M_A, scale)):
            failed.append(f"equipollence of {ch.prefix}: F {F2[i]} vs {F[i]}, M_A {M2[i]} vs {M_A}")
    # Phi = lambda A (eqs. 38-41) and the generalized force of the reported loads
    A = np.asarray(top.A(q, t))
    Phi_indep = lam[:, None] * A
    if not close(Phi, Phi_indep, np.abs(Phi_indep).max()):
        failed.append(f"Phi = lambda A: differs by {np.abs(Phi - Phi_indep).max():.3g}")
    Jc = [np.asarray(x) for x in top.channel_jacobians(q)]
    Qgen = sum(F[i] @ Jc[2 * i] + M[i] @ Jc[2 * i + 1] for i in range(len(chans))) if chans else np.zeros(eqs.nq)
    scale = max(np.abs(Phi_indep).sum(axis=0).max(), 1e-300)
    if not close(Qgen, Phi_indep.sum(axis=0), scale):
        failed.append(f"generalized force of the loads vs sum lambda A: differs by "
                      f"{np.abs(Qgen - Phi_indep.sum(axis=0)).max():.3g}")
    return failed, ill_conditioned


@pytest.mark.parametrize("n_systems", [IN_SUITE, pytest.param(N_SYSTEMS, marks=pytest.mark.slow)])
def test_identities_hold_on_random_systems(n_systems):
    rng = np.random.default_rng(SEED)
    checked, errors, failures, topologies, ill, tally = 0, {}, [], 0, 0, {}
    while checked < n_systems:
        top_seed = int(rng.integers(2**31))
        trng = np.random.default_rng(top_seed)
        try:
            top = Topology(trng, topologies)
        except OcpConstraintsError as exc:     # a joint the library refuses to build: counted, never silent
            errors[type(exc).__name__] = errors.get(type(exc).__name__, 0) + 1
            continue
        topologies += 1
        for kind, two in top.kinds_two:
            tally[f"{kind}{'(2 bodies)' if two else '(ground)'}"] = tally.get(f"{kind}{'(2 bodies)' if two else '(ground)'}", 0) + 1
        tally["e != 0"] = tally.get("e != 0", 0) + sum(c.name.startswith(("drive", "slide")) for c in top.eqs.constraints)
        tally[f"{len(top.eqs.bodies)} bodies"] = tally.get(f"{len(top.eqs.bodies)} bodies", 0) + 1
        for _ in range(DRAWS):
            try:
                bad, ill_conditioned = check_system(top, trng)
            except OcpConstraintsError as exc:
                errors[type(exc).__name__] = errors.get(type(exc).__name__, 0) + 1
                continue
            checked += 1
            ill += ill_conditioned
            if bad:
                failures.append(f"topology seed {top_seed} ({top.kinds}):\n  " + "\n  ".join(bad))
    print(f"\n{checked} systems on {topologies} random topologies; library errors (raised, not returned): {errors}; "
          f"{ill} systems with cond(KKT) > {KKT_COND_LIMIT:g} (checked all the same); "
          f"topologies: {dict(sorted(tally.items()))}")
    assert not failures, f"{len(failures)} of {checked} systems fail:\n" + "\n".join(failures[:10])
