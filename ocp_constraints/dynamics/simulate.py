"""Forward dynamics with constraint loads as outputs.

Method (index reduction with projection): between output samples CVODES integrates
``q' = N(q) u`` and ``u'`` from the KKT system of the acceleration-level constraints
``G u' + gamma = 0`` (see :attr:`SystemEquations.forward_dynamics`), at tight tolerances.
At every output sample the state is projected back onto the constraint manifold:
positions by Gauss-Newton on the holonomic forms ``phi(q, t) = 0`` (and unit norm for
quaternions), speeds by the kinetic-energy-metric projection onto ``G u + e = 0``. The
size of each correction (the drift the integrator produced) is reported, not hidden.
The work of every constraint, ``int -lambda_k e_k dt`` (eq. 27), and of the applied
loads other than gravity are integrated as quadratures alongside, so energy balances can
be checked to integrator accuracy.
"""
from __future__ import annotations

from contextlib import ExitStack
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..mechanics.equations import SystemEquations
from ..errors import ModelError, SimulationError
from ..mechanics.rotations import UnitQuaternion
from ..errors import RunInterrupted, SingularConfigurationError, interruption_reason
from .integrators import COMPILE_ABOVE_NX, integrators_for  # noqa: F401 (COMPILE_ABOVE_NX: its old home)
from ..output.signals import polling, raise_if_signalled, signal_mark, signal_since, watching_sigint
from .preflight import check_initial_state, check_resources, input_function, state_vector
from .trajectory import Trajectory
from ..mechanics.state import project_with_drift




@dataclass
class SimulationOptions:
    """Integrator settings (the defaults keep energy and residual errors near 1e-10).

    ``dt`` is the output sampling; ``projection_interval`` how often the state is put
    back on the constraint manifold (CVODES restarts there, so not too often). A segment
    that ends with a residual above ``drift_tolerance`` is integrated again in halves
    (down to one sample), so the drift stays under the tolerance wherever the sampling
    allows; the interval grows back while the residuals stay far below it.
    """

    dt: float = 0.01
    rtol: float = 1e-12
    atol: float = 1e-12
    #: 2 s: each projection restarts CVODES (Adams from order 1); 0.5 s cost 1.2-2x the run time of
    #: 2 s on the bench scenes at equal error (the drift check halves a segment where needed).
    projection_interval: float = 2.0
    #: None: ``max(1e-9, 100 max(rtol, atol))``, a drift the requested accuracy allows (a fixed 1e-9
    #: made loose tolerances project, and restart CVODES, at every sample: slower than tight ones).
    drift_tolerance: float | None = None
    max_steps: int = 500_000
    method: str = "adams"
    #: Bytes the run may use at its peak (None: 80% of the memory available at the start); a run
    #: estimated above it is refused with :class:`~ocp_constraints.errors.ResourceLimitError`.
    max_memory: float | None = None
    #: "auto" (compiled model functions where compiling pays, or already cached), "always" or "never"
    #: (CasADi's virtual machine); see :mod:`.compiled`.
    compiled: str = "auto"
    #: "maximal" (every body's coordinates, projection) or "joint": the ODE in joint coordinates, for
    #: models whose constraints are all library joints and that have no inputs (:mod:`.joint_simulation`).
    coordinates: str = "maximal"

    @property
    def drift_limit(self) -> float:
        """The drift tolerance in effect (see ``drift_tolerance``)."""
        if self.drift_tolerance is not None:
            return self.drift_tolerance
        return max(1e-9, 100 * max(self.rtol, self.atol))

    def validate(self) -> None:
        for name in ("dt", "rtol", "atol", "projection_interval", "drift_tolerance"):
            v = getattr(self, name)
            if v is None and name == "drift_tolerance":
                continue
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ModelError(f"simulation option '{name}' must be a positive number, got {v!r}")
        if self.compiled not in ("auto", "always", "never"):
            raise ModelError(f"simulation option 'compiled' must be 'auto', 'always' or 'never', got {self.compiled!r}")
        if self.coordinates not in ("maximal", "joint"):
            raise ModelError(f"simulation option 'coordinates' must be 'maximal' or 'joint', got {self.coordinates!r}")
        if self.method not in ("adams", "bdf"):
            raise ModelError(f"simulation option 'method' must be 'adams' or 'bdf', got {self.method!r}")


def _failure_message(eqs: SystemEquations, q: np.ndarray, t0: float, t1: float, exc: Exception) -> str:
    """Why the integrator failed: a nearby Euler singularity, or the solver's own words."""
    start = 0
    for b in eqs.bodies:
        n = b.q.numel()
        rot = b.rotation
        if not isinstance(rot, UnitQuaternion):
            volume = abs(float(rot.basis_volume(q[start + 3 : start + n])))
            if volume < 0.05:
                return (
                    f"integrator failed between t = {t0:g} and {t1:g}: body '{b.name}' is approaching the "
                    f"singularity of its Euler sequence '{rot.axes}' ({rot.singular_angle_hint()}; theta = "
                    f"{q[start + 4]:.4g} rad, |g_1 . (g_2 x g_3)| = {volume:.2e} at t = {t0:g}). "
                    "Use rotation='quaternion' for this body, or an Euler sequence whose singularity the motion avoids."
                )
        start += n
    return f"integrator failed between t = {t0:g} and {t1:g}: {exc}"


def simulate(
    eqs: SystemEquations,
    q0: np.ndarray,
    u0: np.ndarray,
    t_final: float,
    options: SimulationOptions | None = None,
    inputs: Callable[[float], np.ndarray] | None = None,
    t0: float = 0.0,
    on_start: Callable[[dict], None] | None = None,
) -> Trajectory:
    """Integrate from a consistent state ``(q0, u0)`` at ``t0`` to ``t_final`` (s).

    ``inputs(t)`` gives the actuator inputs (and prescribed motions), taken linear
    between output samples, so an input that enters a constraint has a known rate. Returns a
    :class:`Trajectory` sampled every ``options.dt`` from ``t0``, and at ``t_final`` itself (the
    last step is shorter when the span is not a multiple of ``dt``).

    What enters is checked first (:mod:`.preflight`): ``q0``, ``u0`` of the model's length, finite,
    on the constraints (:class:`InconsistentStateError` naming the violated constraints, e.g. for a
    state not from :func:`consistent_state`); constraints and loads finite; the accelerations
    determined (no zero inertia about a free axis); ``inputs`` callable with the model's number of
    finite values; ``dt`` not longer than the run; the memory the samples need (a
    :class:`ResourceLimitError` with the estimate beyond ``options.max_memory``). ``on_start``, if
    given, is called with that estimate when the integration starts.

    A singular Euler configuration or an integrator failure raises :class:`SimulationError` whose
    ``partial`` attribute holds the trajectory up to the last good sample. SIGINT (Ctrl-C), or
    SIGTERM under the command line, raises :class:`RunInterrupted` (a ``KeyboardInterrupt``) whose
    ``partial`` holds the trajectory up to the last complete sample (``status`` "interrupted by SIGINT").
    """
    opts = options or SimulationOptions()
    opts.validate()
    if not np.isfinite(t_final) or t_final <= t0:
        raise ModelError(f"t_final must be a finite time after t0 = {t0}, got {t_final!r}")
    span = float(t_final - t0)
    if opts.dt > span * (1 + 1e-9):
        raise ModelError(f"dt = {opts.dt:g} s is longer than the run (t_final - t0 = {span:g} s): no sample would "
                         f"lie between the start and the end. Use dt <= {span:g} s")
    n_in = eqs.inputs.numel()
    input_at = input_function(eqs, inputs)
    q0, u0 = state_vector(eqs, q0, "q0"), state_vector(eqs, u0, "u0")
    check_initial_state(eqs, q0, u0, t0, input_at(t0))
    # Samples every dt from t0, and t_final itself (never past it); counted before any is made.
    n_full = int(np.floor(span / opts.dt + 1e-9))
    short_last = span - n_full * opts.dt > 1e-9 * opts.dt
    integrators = integrators_for(eqs, opts) if opts.coordinates == "maximal" else None
    estimate = check_resources(eqs, n_full + 1 + short_last, span, opts.dt, opts.max_memory,
                               lambda: _seconds_per_sample(eqs, q0, u0, t0, n_full, inputs, opts))
    times = t0 + opts.dt * np.arange(n_full + 1)
    if short_last:
        times = np.append(times, t_final)
    times[-1] = t_final
    n_steps = len(times) - 1
    last_step = float(times[-1] - times[-2])
    if on_start is not None:
        on_start({**estimate, "t0": t0, "t_final": float(t_final), "dt": opts.dt, "last_step": last_step})
    if opts.coordinates == "joint":
        from .joint_simulation import simulate_joint

        return simulate_joint(eqs, q0, u0, times, opts)
    # With inputs, CVODES restarts at every sample (the inputs are linear per sample).
    longest = 1 if n_in else max(1, int(round(opts.projection_interval / opts.dt)))
    per_segment = longest
    traj = Trajectory(eqs, success=False, status="running")
    q, u = np.asarray(q0, float).copy(), np.asarray(u0, float).copy()
    work = np.zeros(eqs.nc + 1)

    samples = integrators.samples

    def record(ks, Q, U, works, drift_q=0.0, drift_u=0.0) -> None:
        """Samples ``ks`` (columns of ``Q``, ``U``, ``works``), added as one block; the last gets the drifts."""
        ks = list(ks)
        m = len(ks)
        T = times[ks]
        W = np.column_stack([input_at(times[k]) for k in ks]) if n_in else np.zeros((0, m))
        R = np.zeros((n_in, m))
        for j, k in enumerate(ks if n_in else ()):
            if k < n_steps:
                R[:, j] = (input_at(times[k + 1]) - W[:, j]) / (times[k + 1] - times[k])
            else:
                R[:, j] = (W[:, j] - input_at(times[k - 1])) / (times[k] - times[k - 1])
        udot, lam, margin = samples(Q, U, T, W, R)
        drifts = np.zeros((2, m))
        drifts[:, -1] = drift_q, drift_u

        def add(j: int) -> None:   # the first j samples
            traj.extend(T[:j], Q[:, :j].T, U[:, :j].T, udot[:, :j].T, lam[:, :j].T, W[:, :j].T, works[:-1, :j].T,
                        drifts[0, :j], drifts[1, :j], works[-1, :j])

        for j in np.flatnonzero((margin < samples.tolerances[:, None]).any(axis=0)):
            # near a singularity: the bodies' own check decides and words the message
            start = 0
            try:
                for b in eqs.bodies:
                    n = b.q.numel()
                    b.check_singularity(Q[start : start + n, j], f"at t = {T[j]:.6g}")
                    start += n
            except SingularConfigurationError as exc:
                add(j)
                raise traj.stop_early(str(exc)) from exc
        add(m)

    # Ctrl-C (and the CLI's SIGTERM) are recorded, not raised, while the loop runs, and raised between
    # segments: a KeyboardInterrupt inside a CasADi or NumPy call would come out as their own error.
    mark = signal_mark()
    watch = ExitStack()
    watch.enter_context(watching_sigint())
    watch.enter_context(polling())
    try:
        record([0], q[:, None], u[:, None], work[:, None])
        k = 0
        while k < n_steps:
            raise_if_signalled(mark)
            n = min(per_segment, n_steps - k)
            step = opts.dt
            if short_last and k + n == n_steps:   # the shorter last step is integrated on its own
                if n > 1:
                    n -= 1
                else:
                    step = last_step
            w = np.concatenate([input_at(times[k]), input_at(times[k + n])])
            try:
                res = integrators(n, step).named(x0=np.concatenate([q, u]), p=np.concatenate([[times[k], step], w]))
            except RuntimeError as exc:
                if signal_since(mark) is not None:   # not a failure: the run was interrupted
                    raise RunInterrupted(signal_since(mark)) from None
                if n > 1:
                    # Redo the segment one sample at a time, to keep every good sample and
                    # to find where (and why) the integration breaks down; no growing back,
                    # as each failure costs CVODES its max_steps.
                    per_segment = longest = 1
                    continue
                raise traj.stop_early(_failure_message(eqs, q, times[k], times[k + 1], exc)) from exc
            raise_if_signalled(mark)   # a signal during the call: its result is not used
            X = np.asarray(res["xf"]).reshape(eqs.nq + eqs.nu, n)
            W = np.asarray(res["qf"]).reshape(eqs.nc + 1, n)  # constraint works, then applied loads
            if not np.all(np.isfinite(X)):
                raise traj.stop_early(f"state became non-finite between t = {times[k]:g} and {times[k + n]:g}")
            q_end, u_end = X[: eqs.nq, -1], X[eqs.nq :, -1]
            q_new, u_new, drift_q, drift_u = project_with_drift(eqs, q_end, u_end, times[k + n], input_at(times[k + n]))
            if max(drift_q, drift_u) > opts.drift_limit and n > 1:
                # Drifted too far (a fast rotation, a long segment): integrate it again in
                # halves. Nothing of it has been recorded yet.
                per_segment = n // 2
                continue
            q, u = q_new, u_new
            X[: eqs.nq, -1], X[eqs.nq :, -1] = q, u   # the last sample is the projected state
            record(range(k + 1, k + n + 1), X[: eqs.nq], X[eqs.nq :], work[:, None] + W, drift_q, drift_u)
            work = work + W[:, -1]
            if max(drift_q, drift_u) < opts.drift_limit / 16 and per_segment < longest:
                per_segment = min(longest, 2 * per_segment)
            k += n
    except (KeyboardInterrupt, RuntimeError) as exc:
        # Ctrl-C or the CLI's SIGTERM: keep every complete sample, say why the run ended.
        name = signal_since(mark)
        if not isinstance(exc, KeyboardInterrupt) and name is None:
            raise
        err = exc if isinstance(exc, RunInterrupted) else RunInterrupted(name or "SIGINT")
        traj.drop_incomplete_sample()
        traj.success, traj.status = False, interruption_reason(err)
        err.partial = traj
        if err is exc:
            raise
        raise err from None
    finally:
        watch.close()
    traj.success, traj.status = True, "completed"
    return traj


def _seconds_per_sample(eqs: SystemEquations, q0, u0, t0: float, n_full: int, inputs, opts: SimulationOptions) -> float:
    """Seconds a sample costs, from two short runs of this simulation (50 and 150 samples; their
    difference leaves out the fixed cost of building the integrators). For a refused run's message."""
    import time
    from dataclasses import replace

    small = replace(opts, max_memory=None)
    took = []
    for n in (min(50, n_full), min(150, n_full)):
        started = time.perf_counter()
        try:
            simulate(eqs, q0, u0, t0 + n * opts.dt, small, inputs=inputs, t0=t0)
        except SimulationError:
            pass
        took.append((n, time.perf_counter() - started))
    (n1, s1), (n2, s2) = took
    return (s2 - s1) / (n2 - n1) if n2 > n1 and s2 > s1 else s2 / max(n2, 1)
