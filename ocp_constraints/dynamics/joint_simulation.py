"""Forward simulation in joint coordinates: ``SimulationOptions(coordinates="joint")`` (paper sec. 5, eqs. 34-44).

Where every constraint of a model is a library joint with a known parameterization (revolute,
prismatic, weld; :class:`~ocp_constraints.mechanics.generalized.JointCoordinates` covers them all,
none is left with a multiplier of its own) and the model has no inputs, the motion is the ODE
``p' = u_r``, ``M_r u_r' = f_r`` in the joint coordinates ``p`` (the pendulum: one angle instead of
six coordinates, six speeds and five multipliers of a KKT system). CVODES integrates it over the
whole run in one call; there is nothing to project, as the bodies' coordinates and speeds computed
from ``p, u_r`` satisfy the joints' constraints identically (their drift is zero, and reported so).
At the samples every body's ``q, u, u'`` and every joint's multipliers follow from the balances
body by body (:meth:`JointCoordinates.multiplier_expression`, eqs. 38-41): one mapped evaluation.
The applied loads' work is a quadrature; the joints' constraint work is zero (scleronomic joints,
``e = 0``: checked, eq. 27).

The start ``(q0, u0)`` is mapped to ``(p0, u_r0)`` by Gauss-Newton on ``q(p) = q0`` from the joint
coordinates' zero and least squares on ``J u_r = u0``; a start the joint coordinates cannot reach
(an Euler angle on another branch, a quaternion of the opposite sign) is refused with a
:class:`ModelError` that says to use ``coordinates="maximal"``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..errors import ModelError, RunInterrupted, SingularConfigurationError
from ..mechanics.equations import SystemEquations
from ..mechanics.fast_eval import Buffered
from ..mechanics.rotations import UnitQuaternion
from ..mechanics.state import margin_function
from .trajectory import Trajectory

#: Joint simulations of models met before in this process, by fingerprint (see integrators._SHARED).
_SHARED: dict[tuple, "JointSimulation"] = {}
_SHARED_SIZE = 32


class JointSimulation:
    """The functions of one model in joint coordinates (built once: ~10 ms for the pendulum)."""

    def __init__(self, eqs: SystemEquations):
        from ..mechanics.generalized import JointCoordinates

        names = ", ".join(eqs.constraint_names[:3]) + (" ..." if eqs.nc > 3 else "")
        if eqs.inputs.numel():
            raise ModelError(f"simulation option coordinates='joint': the model has inputs "
                             f"({eqs.inputs.numel()}); use coordinates='maximal'")
        try:
            jc = JointCoordinates(eqs)
        except ModelError as exc:
            raise ModelError(f"simulation option coordinates='joint': the joint coordinates of this model cannot be "
                             f"built ({exc}); use coordinates='maximal'") from exc
        if jc.nc:
            raise ModelError(f"simulation option coordinates='joint': constraints {', '.join(jc.constraint_names[:3])} "
                             "are no library joint with a parameterization (a loop closure, a contact or a constraint "
                             "written by hand); use coordinates='maximal'")
        if not jc.maps:
            raise ModelError(f"simulation option coordinates='joint': no body hangs on a library joint ({names}); use "
                             "coordinates='maximal'")
        e_joint = jc.substitute(eqs.e)
        if not all(ca.SX(e_joint)[k].is_zero() for k in range(e_joint.numel())):
            raise ModelError("simulation option coordinates='joint': a joint constraint prescribes a motion (e != 0); "
                             "use coordinates='maximal'")
        self.eqs, self.jc = eqs, jc
        a = jc.forward_accelerations          # M_r^{-1} f_r: no multipliers remain (nc = 0)
        _, lam_r = jc.multiplier_symbols
        a = ca.substitute(a, lam_r, ca.SX(0, 1)) if lam_r.numel() else a
        x = ca.vertcat(jc.q, jc.u)
        self.dae = {"x": x, "t": eqs.t, "ode": ca.vertcat(jc.qdot, a), "quad": jc.substitute(eqs.applied_power)}
        a_sym, _ = jc.multiplier_symbols
        udot = ca.substitute(jc.accelerations_full(a_sym), a_sym, a)
        lam = ca.substitute(jc.multiplier_expression, a_sym, a)
        if lam_r.numel():
            lam = ca.substitute(lam, lam_r, ca.SX(0, 1))
        margins = [margin_function(b.rotation)(jc.q_full[self._slice(eqs, k)][3:]) for k, b in enumerate(eqs.bodies)]
        self.sample = ca.Function("joint_samples", [jc.q, jc.u, eqs.t],
                                  [jc.q_full, jc.u_full, udot, lam, ca.vertcat(*margins)])
        self.pose = Buffered(jc.pose_functions)
        self.tolerances = np.array([1e-12 if isinstance(b.rotation, UnitQuaternion) else b.rotation.singularity_tolerance
                                    for b in eqs.bodies], float)
        self._integrators: dict[tuple, Buffered] = {}
        self._maps: dict[int, Buffered] = {}

    @staticmethod
    def _slice(eqs: SystemEquations, k: int) -> slice:
        start = sum(b.q.numel() for b in eqs.bodies[:k])
        return slice(start, start + eqs.bodies[k].q.numel())

    def start(self, q0: np.ndarray, u0: np.ndarray) -> np.ndarray:
        """``(p0, u_r0)`` of the bodies' ``(q0, u0)`` (module docstring); ModelError if none fits."""
        p = self.jc.reference_point()
        scale = 1.0 + float(np.abs(q0).max(initial=0.0))
        nq, nu, n = len(q0), len(u0), len(p)

        def pose(p):     # a one-column Jacobian comes back as a vector
            q, D, J = self.pose(p)
            return q, D.reshape(nq, n, order="F") if D.ndim == 1 else D, J.reshape(nu, n, order="F") if J.ndim == 1 else J

        for _ in range(60):
            q, D, J = pose(p)
            r = q - q0
            if np.abs(r).max(initial=0.0) <= 1e-13 * scale:
                break
            p = p - np.linalg.lstsq(D, r, rcond=None)[0]
        q, D, J = pose(p)
        if not np.abs(q - q0).max(initial=0.0) <= 1e-10 * scale:
            raise ModelError("simulation option coordinates='joint': the start coordinates q0 are not reached by the "
                             f"joint coordinates from their zero (largest difference {np.abs(q - q0).max():.2e}: an "
                             "Euler angle on another branch or a quaternion of the opposite sign); use "
                             "coordinates='maximal'")
        ur = np.linalg.lstsq(J, u0, rcond=None)[0]
        if not np.abs(J @ ur - u0).max(initial=0.0) <= 1e-10 * (1.0 + float(np.abs(u0).max(initial=0.0))):
            raise ModelError("simulation option coordinates='joint': the start speeds u0 are not those of the joints "
                             "(u0 violates a joint's velocity constraint); use coordinates='maximal'")
        return np.concatenate([p, ur])

    def integrator(self, times: np.ndarray, opts) -> Buffered:
        """CVODES over ``times[1:]`` from ``times[0]`` (cached by the grid and the settings)."""
        key = (float(times[0]), len(times), float(times[1] - times[0]), float(times[-1]),
               opts.rtol, opts.atol, opts.max_steps, opts.method)
        if key not in self._integrators:
            span = float(times[-1] - times[0])
            self._integrators[key] = Buffered(ca.integrator(
                "joint_forward", "cvodes", self.dae, float(times[0]), [float(x) for x in times[1:]],
                {"abstol": opts.atol, "reltol": opts.rtol, "max_num_steps": opts.max_steps,
                 "min_step_size": 1e-13 * span, "linear_multistep_method": opts.method}))
        return self._integrators[key]

    def samples(self, X: np.ndarray, t: np.ndarray) -> list[np.ndarray]:
        """``q, u, u', lambda, margins`` (columns) at the states ``X`` (columns ``p, u_r``) and times ``t``."""
        m = X.shape[1]
        if m not in self._maps:
            self._maps[m] = Buffered(self.sample.map(m) if m > 1 else self.sample)
        n = self.jc.nq
        out = self._maps[m](X[:n], X[n:], t.reshape(1, m))
        return [o.reshape(-1, m, order="F") if o.ndim == 1 else o for o in out]


def joint_simulation(eqs: SystemEquations) -> JointSimulation:
    """The :class:`JointSimulation` of ``eqs``: kept on ``eqs`` and shared between equal models of this process."""
    from .integrators import fingerprint

    mine = eqs.__dict__.get("_joint_simulation")
    if mine is None:
        key = (fingerprint(eqs), tuple(b.rotation.singularity_tolerance if not isinstance(b.rotation, UnitQuaternion)
                                       else 1e-12 for b in eqs.bodies))
        mine = _SHARED.pop(key, None) or JointSimulation(eqs)
        _SHARED[key] = mine            # most recently used last
        while len(_SHARED) > _SHARED_SIZE:
            del _SHARED[next(iter(_SHARED))]
        eqs.__dict__["_joint_simulation"] = mine
    return mine


def simulate_joint(eqs: SystemEquations, q0: np.ndarray, u0: np.ndarray, times: np.ndarray, opts) -> Trajectory:
    """The run of :func:`~.simulate.simulate` in joint coordinates at the sample ``times`` (module docstring)."""
    from ..output.signals import polling, raise_if_signalled, signal_mark, signal_since, watching_sigint

    js = joint_simulation(eqs)
    x0 = js.start(q0, u0)
    traj = Trajectory(eqs, success=False, status="running")
    mark = signal_mark()
    try:
        with watching_sigint(), polling():
            try:
                res = js.integrator(times, opts).named(x0=x0)
            except RuntimeError as exc:
                if signal_since(mark) is not None:
                    raise RunInterrupted(signal_since(mark)) from None
                _record(js, traj, x0[:, None], times[:1], np.zeros(1))
                raise traj.stop_early(f"integrator failed between t = {times[0]:g} and {times[-1]:g} "
                                      f"(joint coordinates): {exc}") from exc
            raise_if_signalled(mark)
    except KeyboardInterrupt as exc:
        from ..errors import interruption_reason

        err = exc if isinstance(exc, RunInterrupted) else RunInterrupted(signal_since(mark) or "SIGINT")
        traj.success, traj.status = False, interruption_reason(err)
        err.partial = traj
        raise err from None
    n = len(times) - 1
    X = np.column_stack([x0, np.asarray(res["xf"]).reshape(len(x0), n)])
    applied = np.concatenate([[0.0], np.asarray(res["qf"]).reshape(n)])
    if not np.all(np.isfinite(X)):
        _record(js, traj, X[:, :1], times[:1], applied[:1])
        raise traj.stop_early(f"state became non-finite between t = {times[0]:g} and {times[-1]:g}")
    _record(js, traj, X, times, applied)
    traj.success, traj.status = True, "completed"
    return traj


def _record(js: JointSimulation, traj: Trajectory, X: np.ndarray, T: np.ndarray, applied: np.ndarray) -> None:
    """Samples in columns of ``X``; stops at the first singular configuration (the bodies' own check words it)."""
    eqs = js.eqs
    Q, U, UD, L, margin = js.samples(X, T)
    m = X.shape[1]

    def add(j: int) -> None:      # the first j samples; scleronomic joints: e = 0, no constraint work (eq. 27)
        traj.extend(T[:j], Q[:, :j].T, U[:, :j].T, UD[:, :j].T, L[:, :j].T, np.zeros((j, 0)), np.zeros((j, eqs.nc)),
                    np.zeros(j), np.zeros(j), applied[:j])

    for j in np.flatnonzero((margin < js.tolerances[:, None]).any(axis=0)):
        try:          # near a singularity: the bodies' own check decides and words the message
            for k, b in enumerate(eqs.bodies):
                b.check_singularity(Q[js._slice(eqs, k), j], f"at t = {T[j]:.6g}")
        except SingularConfigurationError as exc:
            add(j)
            raise traj.stop_early(str(exc)) from exc
    add(m)

__all__ = ["JointSimulation", "joint_simulation", "simulate_joint"]
