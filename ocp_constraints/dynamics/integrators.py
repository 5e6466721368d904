"""The integrators of a forward simulation, built once per model and settings.

:class:`ModelFunctions` builds what a simulation evaluates (the DAE for CVODES and the samples'
accelerations, multipliers and singularity margins), :class:`Integrators` the CVODES integrators
over ``n`` output samples and the samples' mapped function, compiled to C or in CasADi's virtual
machine (:mod:`.compiled`). :func:`integrators_for` keeps them on the model's equations and shares
them between equal models of a process (the same scene built again, a sweep): the integrators and
the loaded libraries are reused, only the (cheap) functions' graphs are built again to recognise them.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..mechanics.equations import SystemEquations
from ..mechanics.fast_eval import Buffered
from ..mechanics.rotations import UnitQuaternion
from ..mechanics.state import margin_function, projection_parts
from .compiled import compiled, is_cached

#: State size from which "auto" compiles the model functions. Measured (bench.peers.forward_duel, 10 s runs,
#: medians of 3 interleaved, load ~11 on 2 cores): with the libraries cached, compiled runs are 25-30% faster
#: on the sliding disk and within the noise on the pendulum, while compiling the DAE with its Jacobian and
#: the sample function takes ~4 s each under load; no break-even size was measured, so "auto" uses
#: libraries already in the cache (checking costs ~1-2 ms) and compiles nothing itself.
COMPILE_ABOVE_NX = 10**9


class Integrators:
    """CVODES integrators over ``n`` output samples of ``dt``, built once per ``n``, and the samples'
    function, for one model's functions (:class:`ModelFunctions`) and one set of settings ``opts`` (a
    :class:`~ocp_constraints.dynamics.simulate.SimulationOptions`)."""

    def __init__(self, functions: ModelFunctions, opts):
        self.opts = opts
        dae_key, sample_key = functions.keys if opts.compiled != "never" else (None, None)
        self.compile = opts.compiled == "always" or (opts.compiled == "auto" and (
            functions.dae.size1_in(1) >= COMPILE_ABOVE_NX
            or (is_cached(functions.dae, with_jacobian=True, key=dae_key) and is_cached(functions.samples, key=sample_key))))
        # Compiled (the DAE with its Jacobian for CVODES's Newton iterations), or CasADi's VM.
        self.dae_function = compiled(functions.dae, with_jacobian=True, key=dae_key) if self.compile else functions.dae
        self._cache: dict[tuple[int, float], Buffered] = {}
        self.samples = SampleFunctions(compiled(functions.samples, key=sample_key) if self.compile else functions.samples,
                                       functions.tolerances)

    def __call__(self, n: int, step: float) -> Buffered:
        """``n`` samples ``step`` apart (the last step of a run may be shorter than ``dt``); called
        through CasADi's function buffer (:mod:`~ocp_constraints.mechanics.fast_eval`)."""
        o = self.opts
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


class ModelFunctions:
    """The functions a simulation of ``eqs`` evaluates: ``dae`` (``q' = N u``, ``u'`` from the KKT
    system, the constraints' and applied loads' power as quadratures; MX calling the model's SX
    functions, so it works whether the forward dynamics are one SX graph or a sparse numerical
    solve) and ``samples`` (``(q, u, t, w, w') -> (u', lambda, singularity margins)``; a body's
    configuration is singular where its margin falls below its tolerance: Euler angles
    ``|g_1 . (g_2 x g_3)|``, quaternion the norm). ``keys``: their content as :mod:`.compiled` names
    libraries by, the DAE's serialized graph (and the margins', which with it determine ``samples``)."""

    def __init__(self, eqs: SystemEquations):
        e = eqs
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
        none = ca.MX.sym("none", 0)
        self.dae = ca.Function("forward_dae", [tau, ca.vertcat(q, u), none, ca.vertcat(t0, h, w0, w1), none],
                               [ca.densify(ca.vertcat(qdot, udot)), ca.MX(0, 1), ca.densify(power), ca.MX(0, 1)],
                               ca.dyn_in(), ca.dyn_out())
        margins, tols = [], []
        for b in eqs.bodies:
            rot, r = b.rotation, b.rotation_parameters
            margins.append(margin_function(rot)(r))
            tols.append(1e-12 if isinstance(rot, UnitQuaternion) else rot.singularity_tolerance)
        self.tolerances = np.array(tols, float)
        margin = ca.Function("margins", [eqs.q], [ca.vertcat(*margins)])
        args = [ca.MX.sym(n, eqs.nq if n == "q" else eqs.nu if n == "u" else 1 if n == "t" else n_in)
                for n in ("q", "u", "t", "w", "rate")]
        udot, lam = eqs.forward_dynamics(*args)
        self.samples = ca.Function("sample_values", args, [udot, lam, margin(args[0])])
        self._margin = margin

    @property
    def keys(self) -> tuple[str, str]:
        """(DAE, samples) content keys; serialized once per model (1-2 ms each)."""
        if not hasattr(self, "_keys"):
            dae = self.dae.serialize()
            self._keys = (dae, "sample_values\0" + dae + "\0" + self._margin.serialize())
        return self._keys


#: Integrators of models simulated before in this process, by their :func:`fingerprint` (the same
#: scene built again, a sweep, a multi-start's re-integrations): the integrators, the loaded libraries
#: and the projection's function are reused, not built again. At most _SHARED_SIZE, the least
#: recently used dropped.
_SHARED: dict[tuple, Integrators] = {}
_SHARED_SIZE = 32


def fingerprint(eqs: SystemEquations) -> str:
    """Everything a simulation of ``eqs`` evaluates, serialized: the kinematics ``q' = N u``, the mass
    matrix, applied and gyroscopic loads, ``G``, ``e``, ``gamma``, the applied loads' power, the
    position forms ``phi`` and the singularity margins, as one SX function (0.7 ms on the pendulum,
    against ~5 ms to build and serialize the simulation's MX functions). Equal models have equal
    fingerprints."""
    margins = ca.vertcat(*[margin_function(b.rotation)(b.rotation_parameters) for b in eqs.bodies])
    return ca.Function("fingerprint", [eqs.q, eqs.u, eqs.t, eqs.inputs, eqs.input_rates],
                       [eqs.qdot, eqs.mass_matrix, eqs.forces, eqs.G, eqs.e, eqs.gamma, eqs.applied_power,
                        eqs.phi, margins]).serialize()


def integrators_for(eqs: SystemEquations, opts) -> Integrators:
    """The integrators of ``eqs`` for these settings: kept on ``eqs``, and shared between equal models
    of this process (same :func:`fingerprint` and singularity tolerances), with the projection's
    function (:func:`~ocp_constraints.mechanics.state.projection_parts`)."""
    settings = (opts.rtol, opts.atol, opts.max_steps, opts.method, opts.compiled)
    mine = eqs.__dict__.setdefault("_simulation_integrators", {})
    if settings not in mine:
        tolerances = tuple(1e-12 if isinstance(b.rotation, UnitQuaternion) else b.rotation.singularity_tolerance
                           for b in eqs.bodies)
        shared = (fingerprint(eqs), tolerances, settings)
        if shared not in _SHARED:
            integ = Integrators(ModelFunctions(eqs), opts)
            integ.projection = projection_parts(eqs)
            _SHARED[shared] = integ
            while len(_SHARED) > _SHARED_SIZE:
                del _SHARED[next(iter(_SHARED))]
        else:
            _SHARED[shared] = _SHARED.pop(shared)   # most recently used last
        mine[settings] = _SHARED[shared]
        eqs.__dict__.setdefault("_projection_parts", mine[settings].projection)
    return mine[settings]


class SampleFunctions:
    """``(q, u, t, w, w') -> (u', lambda, singularity margins)`` over the columns of a segment, in
    one (mapped) call: no per-sample Python work."""

    def __init__(self, function: ca.Function, tolerances: np.ndarray):
        self.function = function
        self.tolerances = tolerances
        self._maps: dict[int, Buffered] = {}

    def __call__(self, Q, U, T, W, R) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m = Q.shape[1]
        if m not in self._maps:
            self._maps[m] = Buffered(self.function.map(m) if m > 1 else self.function)
        out = self._maps[m](Q, U, T.reshape(1, m), W, R)
        return tuple(o.reshape(-1, m, order="F") if o.ndim == 1 else o for o in out)


__all__ = ["COMPILE_ABOVE_NX", "Integrators", "ModelFunctions", "SampleFunctions", "integrators_for"]
