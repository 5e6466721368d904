"""Forward dynamics with constraint loads as outputs.

Method (index reduction with projection): between output samples CVODES integrates
``q' = N(q) u`` and ``u'`` from the KKT system of the acceleration-level constraints
``G u' + gamma = 0`` (see :attr:`SystemEquations.forward_dynamics`), at tight tolerances.
At every output sample the state is projected back onto the constraint manifold:
positions by Gauss-Newton on the holonomic forms ``phi(q, t) = 0`` (and unit norm for
quaternions), speeds by the kinetic-energy-metric projection onto ``G u + e = 0``. The
size of each correction (the drift the integrator produced) is reported, not hidden.
The work of every constraint, ``int -lambda_k e_k dt`` (eq. 27), is integrated as a
quadrature alongside, so energy balances can be checked to integrator accuracy.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import casadi as ca
import numpy as np

from .equations import SystemEquations
from .errors import ModelError, SimulationError
from .rotations import SingularConfigurationError, UnitQuaternion
from .solution import Trajectory


@dataclass
class SimulationOptions:
    """Integrator settings (defaults reach residuals and energy errors near 1e-12)."""

    dt: float = 0.01
    rtol: float = 1e-12
    atol: float = 1e-12
    max_steps: int = 200_000
    project: bool = True

    def validate(self) -> None:
        for name in ("dt", "rtol", "atol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ModelError(f"simulation option '{name}' must be a positive number, got {v!r}")


@dataclass
class _Integrator:
    eqs: SystemEquations
    opts: SimulationOptions
    function: ca.Function = field(init=False)

    def __post_init__(self) -> None:
        e = self.eqs
        t0 = ca.SX.sym("t0")
        tau = ca.SX.sym("tau")
        x = ca.vertcat(e.q, e.u)
        udot, lam = e.forward_dynamics(e.q, e.u, t0 + tau, e.inputs)
        qdot = ca.substitute(e.qdot, e.t, t0 + tau)
        econ = ca.substitute(e.e, e.t, t0 + tau)
        power = -lam * econ if e.nc else ca.SX(0, 1)
        dae = {"x": x, "p": ca.vertcat(t0, e.inputs), "t": tau, "ode": ca.vertcat(qdot, udot), "quad": power}
        self.function = ca.integrator(
            "forward", "cvodes", dae, 0.0, self.opts.dt,
            {"abstol": self.opts.atol, "reltol": self.opts.rtol, "max_num_steps": self.opts.max_steps},
        )


def _project(eqs: SystemEquations, q: np.ndarray, u: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Project ``(q, u)`` onto the constraint manifold; return the corrections' sizes."""
    q = q.copy()
    start = 0
    for b in eqs.bodies:
        n = b.q.numel()
        if isinstance(b.rotation, UnitQuaternion):
            q[start + 3 : start + n] /= np.linalg.norm(q[start + 3 : start + n])
        start += n
    dq_total = 0.0
    if eqs.holonomic:
        for _ in range(4):
            _, _, phi, _, J = eqs.constraint_functions(q, u, t)
            phi, J = np.asarray(phi).ravel(), np.asarray(J)
            if np.abs(phi).max() < 1e-15:
                break
            dq = -np.linalg.lstsq(J, phi, rcond=None)[0]
            q += dq
            dq_total += np.linalg.norm(dq)
    du_norm = 0.0
    if eqs.nc:
        G, _, _, r, _ = eqs.constraint_functions(q, u, t)
        G, r = np.asarray(G), np.asarray(r).ravel()
        M = np.asarray(eqs.mass_matrix_function(q))
        MinvGt = np.linalg.solve(M, G.T)
        du = -MinvGt @ np.linalg.solve(G @ MinvGt, r)
        u = u + du
        du_norm = float(np.linalg.norm(du))
    return q, u, dq_total, du_norm


def simulate(
    eqs: SystemEquations,
    q0: np.ndarray,
    u0: np.ndarray,
    t_final: float,
    options: SimulationOptions | None = None,
    inputs: Callable[[float], np.ndarray] | None = None,
    t0: float = 0.0,
) -> Trajectory:
    """Integrate from a consistent state ``(q0, u0)`` at ``t0`` to ``t_final``.

    ``inputs(t)`` gives the actuator inputs (held constant over each output interval).
    Returns a :class:`Trajectory` sampled every ``options.dt``. A singular Euler
    configuration or an integrator failure raises :class:`SimulationError` whose
    ``partial`` attribute holds the trajectory up to the last good sample.
    """
    opts = options or SimulationOptions()
    opts.validate()
    if not np.isfinite(t_final) or t_final <= t0:
        raise ModelError(f"t_final must be a finite time after t0 = {t0}, got {t_final!r}")
    n_in = eqs.inputs.numel()
    if n_in and inputs is None:
        raise ModelError(f"model '{eqs.model.name}' has inputs {list(eqs.model.inputs)}: pass inputs(t)")
    integrator = _Integrator(eqs, opts).function
    n_steps = int(np.ceil((t_final - t0) / opts.dt - 1e-9))
    times = t0 + opts.dt * np.arange(n_steps + 1)
    traj = Trajectory(eqs)
    q, u = np.asarray(q0, float).copy(), np.asarray(u0, float).copy()
    work = np.zeros(eqs.nc)

    def record(k: int, q, u, work, drift_q, drift_u) -> None:
        w = np.zeros(n_in) if not n_in else np.asarray(inputs(times[k]), float).reshape(n_in)
        udot, lam = eqs.forward_dynamics(q, u, times[k], w)
        traj.append(times[k], q, u, np.asarray(udot).ravel(), np.asarray(lam).ravel(), w, work, drift_q, drift_u)

    record(0, q, u, work, 0.0, 0.0)
    for k in range(n_steps):
        w = np.zeros(n_in) if not n_in else np.asarray(inputs(times[k]), float).reshape(n_in)
        try:
            res = integrator(x0=np.concatenate([q, u]), p=np.concatenate([[times[k]], w]))
        except RuntimeError as exc:
            raise SimulationError(
                f"integrator failed between t = {times[k]:g} and {times[k + 1]:g}: {exc}", partial=traj
            ) from exc
        x = np.asarray(res["xf"]).ravel()
        work = work + np.asarray(res["qf"]).ravel()
        q, u = x[: eqs.nq], x[eqs.nq :]
        if not np.all(np.isfinite(x)):
            raise SimulationError(f"state became non-finite at t = {times[k + 1]:g}", partial=traj)
        dq = du = 0.0
        if opts.project:
            q, u, dq, du = _project(eqs, q, u, times[k + 1])
        start = 0
        try:
            for b in eqs.bodies:
                n = b.q.numel()
                b.check_singularity(q[start : start + n], f"at t = {times[k + 1]:.6g}")
                start += n
        except SingularConfigurationError as exc:
            raise SimulationError(str(exc), partial=traj) from exc
        record(k + 1, q, u, work, dq, du)
    return traj
