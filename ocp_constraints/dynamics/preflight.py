"""Checks before a simulation runs: what enters ``simulate`` is checked where it enters.

- the initial state: its length and shape, finite entries, on the constraints at position level
  (``phi(q0, t0) = 0``) and velocity level (``G u0 + e = 0``, paper eq. 25), every constraint and
  applied load finite there, no redundant constraint;
- the mass matrix on the constraint manifold: the accelerations are determined only if
  ``M`` is positive definite on the speeds the constraints allow (a thin rod's zero inertia
  about its own axis needs a constraint that fixes that spin);
- the inputs function: callable, the model's number of inputs, finite values;
- the resources: the samples the run keeps, its memory at the peak (results written), and
  the memory the machine has.

Each failure is an error of :mod:`ocp_constraints.errors` that names the coordinate,
constraint, body, load or input and says what to do.
"""
from __future__ import annotations

import os
from typing import Callable

import casadi as ca
import numpy as np

from ..mechanics.state import check_regular, checked_start, null_space
from ..errors import InconsistentStateError, ModelError, ResourceLimitError
from ..mechanics.equations import SystemEquations
from ..mechanics.validate import check_constraint_values

#: Largest |phi| (m or rad) and |G u + e| (relative to max(1, |u|)) accepted in an initial state:
#: ten times the drift the integrator is allowed between projections.
STATE_TOLERANCE = 1e-8


def state_vector(eqs: SystemEquations, value, which: str) -> np.ndarray:
    """``q0`` or ``u0`` as a float vector of the model's length; an error naming the entries otherwise."""
    names = eqs.model.coordinate_names if which == "q0" else eqs.model.speed_names
    kind = "coordinates" if which == "q0" else "speeds"
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{which} must be {len(names)} numbers (the {kind} {', '.join(names)}), "
                         f"got {type(value).__name__}: {exc}") from None
    if a.ndim > 1 and sum(d > 1 for d in a.shape) <= 1:
        a = a.reshape(-1)                      # a column or row vector is fine
    if a.ndim != 1 or a.size != len(names):
        raise ModelError(
            f"{which} has shape {a.shape}; model '{eqs.model.name}' has {len(names)} {kind}, in this order: "
            f"{', '.join(names)}. Pass a vector of {len(names)} values (consistent_state() builds one from names)")
    bad = [n for n, v in zip(names, a) if not np.isfinite(v)]
    if bad:
        raise ModelError(f"{which} is not finite for {', '.join(bad)}: give finite initial {kind}")
    return a.copy()


def input_function(eqs: SystemEquations, inputs) -> Callable[[float], np.ndarray]:
    """``inputs(t)`` checked at every call: the model's number of inputs, finite values."""
    names = list(eqs.model.inputs)
    n = len(names)
    if not n:
        return lambda t: np.zeros(0)
    if inputs is None:
        raise ModelError(f"model '{eqs.model.name}' has inputs {names}: pass inputs(t) returning {n} values")
    if not callable(inputs):
        raise ModelError(f"inputs must be a function of t returning {n} values ({', '.join(names)}), "
                         f"got {type(inputs).__name__}; e.g. inputs=lambda t: [0.0] * {n}")

    def checked(t: float) -> np.ndarray:
        raw = inputs(t)
        try:
            w = np.asarray(raw, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"inputs(t) at t = {t:g} returned {raw!r}; it must return {n} numbers "
                             f"({', '.join(names)})") from None
        if w.size != n or (w.ndim > 1 and sum(d > 1 for d in w.shape) > 1):
            raise ModelError(f"inputs(t) at t = {t:g} returned shape {w.shape}; model '{eqs.model.name}' has "
                             f"{n} input(s): {', '.join(names)}. Return one value per input, in this order")
        w = w.reshape(n)
        bad = [nm for nm, v in zip(names, w) if not np.isfinite(v)]
        if bad:
            raise ModelError(f"input(s) {', '.join(repr(b) for b in bad)} are not finite at t = {t:g} "
                             f"(inputs(t) returned {w.tolist()}): give finite inputs at every time")
        return w

    return checked


def check_initial_state(eqs: SystemEquations, q: np.ndarray, u: np.ndarray, t0: float, w: np.ndarray) -> None:
    """The initial state is finite, regular, on the constraints, and its accelerations are determined.

    A state just returned by :func:`~ocp_constraints.mechanics.state.consistent_state` (the very same
    values) had its regularity, constraints and redundancy checked there (more tightly); only the
    loads and the mass matrix are checked then."""
    G = checked_start(eqs, q, u, t0, w)
    if G is not None:
        _check_finite_loads(eqs, q, u, t0, w)
        check_mass_matrix(eqs, q, G)
        return
    check_regular(eqs, q, f"at t = {t0:g}")
    G, e, phi, pi, _ = (np.asarray(x, dtype=float) for x in eqs.constraint_functions(q, u, t0, w))
    names = eqs.constraint_names
    check_constraint_values(eqs, G, e, phi)
    _check_finite_loads(eqs, q, u, t0, w)
    phi = phi.ravel()
    worst = [(abs(phi[k]), names[i]) for k, i in enumerate(eqs.holonomic) if abs(phi[k]) > STATE_TOLERANCE]
    if worst:
        worst.sort(reverse=True)
        listed = ", ".join(f"'{n}' (|phi| = {r:.3g})" for r, n in worst[:5])
        raise InconsistentStateError(
            f"the initial coordinates q0 violate {len(worst)} constraint(s) at position level at t = {t0:g}: "
            f"{listed} (tolerance {STATE_TOLERANCE:g}). The loads of such a state are not the model's. Start from "
            "a consistent state: consistent_state(eqs, coordinates, rates) fixes the speeds and checks the "
            "coordinates, or correct q0")
    pi = pi.ravel()
    tol = STATE_TOLERANCE * max(1.0, float(np.abs(u).max(initial=0.0)))
    worst = sorted(((abs(pi[k]), names[k]) for k in range(eqs.nc) if abs(pi[k]) > tol), reverse=True)
    if worst:
        listed = ", ".join(f"'{n}' (|G u + e| = {r:.3g})" for r, n in worst[:5])
        raise InconsistentStateError(
            f"the initial speeds u0 violate {len(worst)} constraint(s) at t = {t0:g}: {listed} (tolerance "
            f"{tol:.3g}). The loads of such a state are not the model's. Get speeds that satisfy the "
            "constraints from consistent_state(eqs, coordinates, rates), or correct u0")
    eqs.check_redundancy(q, t0)
    check_mass_matrix(eqs, q, G)


def _check_finite_loads(eqs: SystemEquations, q, u, t0, w) -> None:
    m = eqs.model
    args = [eqs.q, eqs.u, eqs.t, eqs.inputs]
    for kind, items in (("force", [(f.name, f.force) for f in m.forces]), ("torque", [(tq.name, tq.torque) for tq in m.torques])):
        for name, expr in items:
            value = np.asarray(ca.Function("load", args, [eqs.to_speeds(expr)])(q, u, t0, w), dtype=float)
            if not np.all(np.isfinite(value)):
                raise ModelError(f"applied {kind} '{name}' is {value.ravel().tolist()} at the initial state: a NaN "
                                 "or inf in its expression or in an input it uses. Fix the expression")


def check_mass_matrix(eqs: SystemEquations, q: np.ndarray, G: np.ndarray | None = None) -> None:
    """Raise :class:`ModelError` if ``M`` is singular on the speeds the constraints allow.

    The KKT matrix ``[M, -G^T; G, 0]`` of the accelerations is regular exactly when ``G`` has full
    row rank (checked by ``check_redundancy``) and ``Z^T M Z`` is positive definite, ``Z`` a basis
    of the null space of ``G``: the free motions must all carry kinetic energy.
    """
    M = np.asarray(eqs.mass_matrix_function(q), dtype=float)
    Z = null_space(G) if G is not None and G.size else np.eye(eqs.nu)
    if not Z.size:
        return
    K = Z.T @ M @ Z
    vals, vecs = np.linalg.eigh(0.5 * (K + K.T))
    scale = max(float(np.abs(M).max()), 1e-300)
    if vals[0] > 1e-10 * scale:
        return
    direction = Z @ vecs[:, 0]
    k = int(np.argmax([np.linalg.norm(direction[6 * i:6 * i + 6]) for i in range(len(eqs.bodies))]))
    body = eqs.bodies[k]
    omega = direction[6 * k + 3:6 * k + 6]
    start = sum(b.q.numel() for b in eqs.bodies[:k])
    Q = np.asarray(ca.Function("Q", [body.q], [body.Q])(q[start:start + body.q.numel()]), dtype=float)
    axis = Q.T @ omega / max(np.linalg.norm(omega), 1e-300)
    axis = axis * np.sign(axis[np.argmax(np.abs(axis))])
    axis_text = "(" + ", ".join(f"{a:.3g}" for a in axis + 0.0) + ")"
    raise ModelError(
        f"body '{body.name}' has zero moment of inertia about its body axis {axis_text} (body basis), and no "
        f"constraint fixes its rotation about that axis: the mass matrix is singular on the motions the "
        "constraints allow, so the accelerations and multipliers are not determined. Give the body a "
        "(small) inertia about that axis, or add a constraint that fixes the spin (e.g. joints.fixed_angle, "
        "or a revolute joint)")


# -- resources ---------------------------------------------------------------------------------

def samples_memory(eqs: SystemEquations, n_samples: int, write: bool = True) -> int:
    """Peak memory (bytes) of a run that keeps ``n_samples`` samples (and writes its results).

    Per sample the trajectory holds the values of ``t, q, u, u', lambda, inputs, work``, two drifts
    and the applied work, in one block per quantity and segment, and once more while the blocks are
    joined into one array; writing adds those as one array each, the state and load columns as
    floats (and a copy), and the text of the widest file (about 25 bytes a number) three times over
    (the buffer, its string, the encoded bytes). ``scripts/simulation_memory.py`` and
    tests/test_bad_input_catalogue.py check this formula against ``tracemalloc`` peaks.
    """
    nin = eqs.inputs.numel()
    arrays = 8 * (eqs.nq + 2 * eqs.nu + 2 * eqs.nc + nin)
    held = 2 * (arrays + 8 * 4)
    if not write:
        return int(n_samples * held)
    n_state = 2 * eqs.nq + eqs.nu + nin + 1            # coordinates, angle rates, speeds, inputs, t
    n_loads = eqs.nc + 10 * len(eqs.load_channels) + 1
    columns = max(n_state, n_loads)
    written = arrays + 8 * (n_state + n_loads) * 2 + columns * 25 * 3
    return int(n_samples * (held + written))


def available_memory() -> int | None:
    """Bytes of memory this machine can still give (``MemAvailable``), or None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return None


def _size(n: float) -> str:
    for unit in ("bytes", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} TB"


def _duration(s: float) -> str:
    if s < 120:
        return f"{s:.3g} s"
    if s < 7200:
        return f"{s / 60:.3g} min"
    if s < 2 * 86400:
        return f"{s / 3600:.3g} h"
    return f"{s / 86400:.3g} days"


def check_resources(eqs: SystemEquations, n_samples: int, span: float, dt: float, max_memory: float | None,
                    seconds_per_sample: Callable[[], float] | None = None) -> dict:
    """The run's estimate ``{"samples", "memory_bytes", "available_bytes", "limit_bytes"}``; a
    :class:`ResourceLimitError` if it needs more than ``max_memory`` (default: 80% of the memory
    available now). ``seconds_per_sample`` (a probe) is called only to put the time in the message."""
    need = samples_memory(eqs, n_samples)
    avail = available_memory()
    limit = max_memory if max_memory is not None else (0.8 * avail if avail is not None else None)
    estimate = {"samples": int(n_samples), "memory_bytes": need, "available_bytes": avail, "limit_bytes": limit}
    if limit is None or need <= limit:
        return estimate
    time_text = ""
    if seconds_per_sample is not None:
        seconds = seconds_per_sample() * n_samples
        estimate["seconds"] = seconds
        time_text = f" and about {_duration(seconds)}"
    have = "" if avail is None else f"; this machine has {_size(avail)} available"
    fit = max(1, int(limit // max(need / n_samples, 1)))
    raise ResourceLimitError(
        f"a simulation of {span:g} s sampled every dt = {dt:g} s keeps {n_samples:,} samples: about {_size(need)} "
        f"of memory{time_text} (limit {_size(limit)}{have}). Shorten t_final, or raise dt: "
        f"{fit:,} samples fit (e.g. dt >= {span / fit:.3g} s)", estimate)
