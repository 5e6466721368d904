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

import casadi as ca
import numpy as np

from ..mechanics.equations import SystemEquations
from ..mechanics.fast_eval import Buffered
from ..errors import ModelError, SimulationError
from ..mechanics.rotations import UnitQuaternion
from ..errors import RunInterrupted, SingularConfigurationError, interruption_reason
from .compiled import compiled, is_cached
from ..output.signals import polling, raise_if_signalled, signal_mark, signal_since, watching_sigint
from .preflight import check_initial_state, check_resources, input_function, state_vector
from .trajectory import Trajectory
from ..mechanics.state import project_with_drift


#: State size from which "auto" compiles the model functions. Measured (bench.peers.forward_duel, 10 s runs,
#: medians of 3 interleaved, load ~11 on 2 cores): with the libraries cached, compiled runs are 25-30% faster
#: on the sliding disk and within the noise on the pendulum, while compiling the DAE with its Jacobian and
#: the sample function takes ~4 s each under load; no break-even size was measured, so "auto" uses
#: libraries already in the cache (checking costs ~1-2 ms) and compiles nothing itself.
COMPILE_ABOVE_NX = 10**9


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
        if self.method not in ("adams", "bdf"):
            raise ModelError(f"simulation option 'method' must be 'adams' or 'bdf', got {self.method!r}")


class _Integrators:
    """CVODES integrators over ``n`` output samples of ``dt``, built once per ``n``."""

    def __init__(self, eqs: SystemEquations, opts: SimulationOptions):
        e = self.eqs = eqs
        self.opts = opts
        # MX symbols that call the model's SX functions: works whether the forward
        # dynamics are one SX graph or a sparse numerical solve (large systems).
        t0, tau, h = ca.MX.sym("t0"), ca.MX.sym("tau"), ca.MX.sym("h")
        q, u = ca.MX.sym("q", e.nq), ca.MX.sym("u", e.nu)
        t = t0 + tau
        # Inputs vary linearly over one output interval of length h: w(tau) = w0 + tau (w1 - w0) / h.
        n_in = e.inputs.numel()
        w0, w1 = ca.MX.sym("w0", n_in), ca.MX.sym("w1", n_in)
        rate = (w1 - w0) / h
        w = w0 + tau * rate
        udot, lam = e.forward_dynamics(q, u, t, w, rate)
        qdot = ca.Function("qdot", [e.q, e.u, e.t], [e.qdot])(q, u, t)
        econ = ca.Function("e", [e.q, e.t, e.inputs], [e.e])(q, t, w)
        applied = ca.Function("applied_power", [e.q, e.u, e.t, e.inputs], [e.applied_power])(q, u, t, w)
        power = ca.vertcat(-lam * econ if e.nc else ca.MX(0, 1), applied)
        self.dae = {"x": ca.vertcat(q, u), "p": ca.vertcat(t0, h, w0, w1), "t": tau,
                    "ode": ca.vertcat(qdot, udot), "quad": power}
        none = ca.MX.sym("none", 0)
        dae = ca.Function("forward_dae", [tau, self.dae["x"], none, self.dae["p"], none],
                          [ca.densify(self.dae["ode"]), ca.MX(0, 1), ca.densify(power), ca.MX(0, 1)],
                          ca.dyn_in(), ca.dyn_out())
        key = _content_key(dae) if opts.compiled != "never" else None   # serialized once, not per use
        self.compile = _use_compiled(opts, dae, key)
        # Compiled (with its Jacobian for CVODES's Newton iterations), or CasADi's VM.
        self.dae_function = compiled(dae, with_jacobian=True, key=key) if self.compile else dae
        self._cache: dict[tuple[int, float], ca.Function] = {}
        self._samples = _SampleFunctions(eqs, self.compile)

    def __call__(self, n: int, step: float | None = None) -> Buffered:
        """``n`` samples ``step`` apart (default ``dt``; the last step of a run may be shorter); called
        through CasADi's function buffer (:mod:`~ocp_constraints.mechanics.fast_eval`)."""
        o = self.opts
        step = o.dt if step is None else step
        if (n, step) not in self._cache:
            grid = [step * (k + 1) for k in range(n)]
            self._cache[n, step] = Buffered(ca.integrator(
                f"forward_{n}", "cvodes", self.dae_function, 0.0, grid,
                {"abstol": o.atol, "reltol": o.rtol, "max_num_steps": o.max_steps,
                 # CVODES gives up once its step falls below 1e-13 of the segment (it only
                 # gets there where the rates blow up, e.g. at an Euler singularity); without
                 # this floor it spends max_steps steps of t + h == t (~1 min) before failing.
                 "min_step_size": 1e-13 * grid[-1],
                 "linear_multistep_method": o.method},
            ))
        return self._cache[n, step]


def _integrators_for(eqs: SystemEquations, opts: SimulationOptions) -> _Integrators:
    """The integrators of ``eqs`` for these settings, built once per model and settings: a batch of
    runs of one model (a sweep, a multi-start's re-integrations) builds the DAE and loads its library once."""
    key = (opts.rtol, opts.atol, opts.max_steps, opts.method, opts.compiled)
    cache = eqs.__dict__.setdefault("_simulation_integrators", {})
    if key not in cache:
        cache[key] = _Integrators(eqs, opts)
    return cache[key]


def _use_compiled(opts: SimulationOptions, dae: ca.Function, key: str | None = None) -> bool:
    """``opts.compiled``: "always", "never", or "auto": the compiled library when the disk cache has
    it (a run with "always" made it), compiled here from ``COMPILE_ABOVE_NX`` states on."""
    if opts.compiled in ("always", "never"):
        return opts.compiled == "always"
    return dae.size1_in(1) >= COMPILE_ABOVE_NX or is_cached(dae, with_jacobian=True, key=key)


def _content_key(f: ca.Function) -> str:
    """``f``'s serialized form (its whole expression graph), the content :mod:`.compiled` names a library
    by: serialized once here for both the cache lookup and the load (the same name as without a key)."""
    return f.serialize()


class _SampleFunctions:
    """``(q, u, t, w, w') -> (u', lambda, singularity margins)`` over the columns of a segment, in
    one (mapped) call: no per-sample Python work. A body's configuration is singular where its
    margin falls below its tolerance (Euler angles: ``|g_1 . (g_2 x g_3)|``; quaternion: the norm)."""

    def __init__(self, eqs: SystemEquations, compile: bool):
        margins, tols = [], []
        for b in eqs.bodies:
            rot, r = b.rotation, b.rotation_parameters
            if isinstance(rot, UnitQuaternion):
                margins.append(ca.norm_2(r))
                tols.append(1e-12)
            else:
                margins.append(ca.fabs(rot.basis_volume(r)))
                tols.append(rot.singularity_tolerance)
        self.tolerances = np.array(tols, float)
        margin = ca.Function("margins", [eqs.q], [ca.vertcat(*margins)])
        args = [ca.MX.sym(n, eqs.nq if n == "q" else eqs.nu if n == "u" else 1 if n == "t" else eqs.inputs.numel())
                for n in ("q", "u", "t", "w", "rate")]
        udot, lam = eqs.forward_dynamics(*args)
        f = ca.Function("sample_values", args, [udot, lam, margin(args[0])])
        self.function = compiled(f) if compile else f
        self._maps: dict[int, Buffered] = {}

    def __call__(self, Q, U, T, W, R) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m = Q.shape[1]
        if m not in self._maps:
            self._maps[m] = Buffered(self.function.map(m) if m > 1 else self.function)
        out = self._maps[m](Q, U, T.reshape(1, m), W, R)
        return tuple(o.reshape(-1, m, order="F") if o.ndim == 1 else o for o in out)


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
    integrators = _integrators_for(eqs, opts)
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
    # With inputs, CVODES restarts at every sample (the inputs are linear per sample).
    longest = 1 if n_in else max(1, int(round(opts.projection_interval / opts.dt)))
    per_segment = longest
    traj = Trajectory(eqs, success=False, status="running")
    q, u = np.asarray(q0, float).copy(), np.asarray(u0, float).copy()
    work = np.zeros(eqs.nc + 1)

    samples = integrators._samples

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
