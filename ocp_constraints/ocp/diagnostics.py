"""Checks of an optimal-control problem before IPOPT starts: milliseconds instead of iterations.

What makes IPOPT wander or fail without a word is found here and named:

- initial coordinates or speeds that neither a constraint (its position form ``phi = 0``, or
  ``G u + e = 0``) nor an initial value fixes: IPOPT would have to choose them, and where
  nothing in the problem depends on them (a cart's heading when only its angular velocity is
  constrained) its KKT system is singular;
- boundary values that no state on the constraints can take (the constraint and its residual);
- boundary values outside the bounds, a free final time whose bounds are reversed or exclude
  the guess, guesses that are not finite or have the wrong shape;
- an NLP larger than the machine's memory (the estimate is in the message).

The degrees of freedom of the model at ``t0`` are counted too (``nq - rank(phi_q)`` positions,
``nu - rank(G)`` speeds) and returned for reports.
"""
from __future__ import annotations

import sys
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import AmbiguousPoseWarning, ModelError, QuaternionSignWarning, SingularConfigurationError
from ..mechanics.rotations import UnitQuaternion
from ..mechanics.scaling import equilibrated
from ..mechanics.state import check_regular, rate_rows
from .boundary_poses import ambiguous_boundary_poses

POSITION_TOL = 1e-8    # m or rad: a boundary value that leaves |phi| above this violates the constraint
VELOCITY_TOL = 1e-8    # m/s or rad/s
BYTES_PER_VARIABLE = 4_000    # peak memory per NLP variable (3,723 measured by scripts/ocp_memory_per_variable.py)
BASE_BYTES = 100 * 2**20      # the process before the NLP (84 MiB measured)


@dataclass
class Diagnostics:
    """Degrees of freedom at ``t0`` and the NLP's size, for reports."""

    position_dof: int
    speed_dof: int
    n_variables: int
    memory_estimate_bytes: float


def check_problem(problem, method) -> Diagnostics:
    """Raise :class:`~ocp_constraints.errors.ModelError` for the first problem found; else the counts."""
    _check_horizon(problem)
    _check_guesses(problem, method)
    _check_boundary_bounds(problem)
    _check_quaternion_ends(problem)
    t0, tf = 0.0, float(problem.t_final)
    free = problem.free_initial_values
    q0, pos_dof = _positions(problem, problem.initial_values, t0, "initial", free)
    # Constraints repeating others leave their multipliers undetermined: named here, not as a singular matrix of the
    # guess's projection (a sixth newcomer's four-bar closed by a second revolute: numpy's LinAlgError, no name).
    problem.eqs.check_redundancy(q0, t0)
    u_dof = _speeds(problem, q0, problem.initial_values, t0, "initial", free)
    if problem.final_values:
        qf, _ = _positions(problem, problem.final_values, tf, "final", None)
        _speeds(problem, qf, problem.final_values, tf, "final", None)
    _check_mirrored_poses(problem)      # after the ends' values are known to be on the constraints
    n_vars = nlp_variables(problem, method)
    estimate = BASE_BYTES + n_vars * BYTES_PER_VARIABLE
    available = _available_memory()
    if available is not None and estimate > 0.8 * available:
        raise ModelError(
            f"the NLP of '{problem.model.name}' with {method.label} (N = {method.intervals}) has {n_vars:,} "
            f"variables and would need about {estimate / 2**30:.1f} GiB, more than the {available / 2**30:.1f} GiB "
            f"this machine has free; use fewer intervals or a higher degree (fewer points for the same accuracy)")
    return Diagnostics(pos_dof, u_dof, n_vars, estimate)


def nlp_variables(problem, method) -> int:
    """Decision variables of the transcription (see :class:`~ocp_constraints.ocp.layout.Layout`)."""
    e = problem.eqs
    P = method.point_count
    n_acc = 1 if method.accelerations_from_speeds is not None else P
    return ((e.nq + e.nu + e.nc + e.inputs.numel()) * P + e.nu * n_acc + e.position_rows.numel() * (P - 1)
            + int(problem.t_final_bounds is not None))


# -- the horizon, guesses and bounds ------------------------------------------------------------
def _check_horizon(problem) -> None:
    # Checked again here, not only by the constructor: an attribute set after it (problem.t_final = -1) ran IPOPT to
    # 'Diverging_Iterates', and t_final_bounds = None after minimize_final_time solved a fixed time to objective 0.
    if not (np.isfinite(problem.t_final) and problem.t_final > 0):
        raise ModelError(f"t_final must be a positive number of seconds, got {problem.t_final!r}")
    if problem.t_final_bounds is None:
        if problem.time_weight:
            raise ModelError(f"the objective weighs the final time ({problem.time_weight:g} per s, "
                             f"minimize_final_time) but the final time is fixed (t_final_bounds is None): set "
                             f"t_final_bounds = (lower, upper), or make a new problem without the time term")
        return
    lo, hi = problem.t_final_bounds
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= 0 or lo > hi:
        raise ModelError(f"t_final_bounds must be 0 < lower <= upper (seconds), got ({lo}, {hi}); "
                         f"swap them if they are reversed")
    if not lo <= problem.t_final <= hi:
        raise ModelError(f"the final-time guess t_final = {problem.t_final} lies outside t_final_bounds "
                         f"({lo}, {hi}); pass a t_final between them")


def _check_guesses(problem, method) -> None:
    t = np.asarray(method.mesh_fractions, float) * problem.t_final
    for name, fn in problem.guess.items():
        try:
            values = np.asarray(fn(t), dtype=float)
        except Exception as exc:  # a user's function: report whatever it raised, with the name
            raise ModelError(f"the guess of '{name}' failed on an array of {t.size} times: "
                             f"{type(exc).__name__}: {exc}; a guess takes an array of times (s) and returns "
                             f"an array of the same shape") from exc
        try:
            values = np.broadcast_to(values, t.shape)
        except ValueError:
            raise ModelError(f"the guess of '{name}' returned shape {values.shape} for {t.size} times; "
                             f"it must return one value per time (use numpy functions, e.g. np.sin, not math.sin)"
                             ) from None
        if not np.all(np.isfinite(values)):
            bad = t[~np.isfinite(values)][0]
            raise ModelError(f"the guess of '{name}' is not finite at t = {bad:g} s ({values[~np.isfinite(values)][0]})")


def _check_boundary_bounds(problem) -> None:
    for which, values in (("initial", problem.initial_values), ("final", problem.final_values)):
        for name, v in values.items():
            if not np.isfinite(v):
                raise ModelError(f"{which} value of '{name}' is not finite ({v})")
            lo, hi = problem.bounds.get(name, (-np.inf, np.inf))
            if not lo <= v <= hi:
                raise ModelError(f"{which} value of '{name}' = {v:g} lies outside its bounds [{lo:g}, {hi:g}]")


# -- positions and speeds at an end ---------------------------------------------------------------
def _positions(problem, values: dict, t: float, which: str, free: set | None) -> tuple[np.ndarray, int]:
    """Coordinates at an end from its values and the position forms (Gauss-Newton on the others).

    Raises if the values violate a constraint; at ``t0`` (``free`` given) also if some
    coordinate stays undetermined. Returns the coordinates and the positional degrees of freedom.
    """
    eqs = problem.eqs
    names = eqs.model.coordinate_names
    given = [i for i, n in enumerate(names) if n in values]
    q = np.array(_guess_at(problem, names, t), float)
    q[given] = [values[names[i]] for i in given]
    unit_quaternions(eqs, q)
    rest = [i for i in range(eqs.nq) if i not in given]
    u0, w0 = np.zeros(eqs.nu), np.zeros(eqs.inputs.numel())
    norm_rows = _quaternion_rows(eqs)
    for _ in range(20):
        _, _, phi, _, J = eqs.constraint_functions(q, u0, t, w0)
        phi, J = np.asarray(phi).ravel(), np.asarray(J).reshape(-1, eqs.nq)
        if not phi.size or np.abs(phi).max() < 1e-13 or not rest:
            break
        q[rest] -= np.linalg.lstsq(J[:, rest], phi, rcond=None)[0]
    _, _, phi, _, J = eqs.constraint_functions(q, u0, t, w0)
    phi, J = np.asarray(phi).ravel(), np.asarray(J).reshape(-1, eqs.nq)
    if phi.size and np.abs(phi).max() > POSITION_TOL:
        order = [k for k in np.argsort(-np.abs(phi)) if abs(phi[k]) > POSITION_TOL]
        culprits = ", ".join(f"'{eqs.constraint_names[eqs.holonomic[k]]}' (residual {phi[k]:.3g})" for k in order)
        raise ModelError(
            f"the {which} values {_listing(values, names)} violate the constraints: no coordinates satisfy "
            f"them at t = {t:g} s; nearest, {culprits}. Change the {which} values or leave out the ones "
            f"these constraints fix")
    dof = eqs.nq - _rank(np.vstack([J, norm_rows(q)]))
    if free is not None:
        fixed = [i for i, n in enumerate(names) if n in values or n in free]
        # The NLP holds each quaternion's length at every point (SystemEquations.position_rows): three of
        # its components fix the fourth up to its sign, as the rotation needs.
        rows = np.vstack([J, norm_rows(q), np.eye(eqs.nq)[fixed]])
        missing = _undetermined(rows, names)
        if missing:
            quaternion = [n for n in missing if n in _quaternion_names(eqs)]
            note = (f" A quaternion body's orientation needs three of its components or all four as a unit "
                    f"quaternion (oc.quaternion_from_rotation(R) makes one)") if quaternion else ""
            note += _singular_note(eqs, q, t)
            raise ModelError(
                f"initial values of {', '.join(missing)} are not determined: no constraint's position form and "
                f"no initial value fixes them, so IPOPT would have to choose them (where nothing depends on them "
                f"it cannot, and wanders). Add them with problem.initial({{{', '.join(repr(n) + ': ...' for n in missing)}}}), "
                f"give the constraints that hold them their position forms (add_constraint(..., position=phi)), "
                f"or declare them free with problem.leave_free({missing}).{note}")
    return q, dof


def _singular_note(eqs, q: np.ndarray, t: float) -> str:
    """Why angles can be undetermined although the joints fix the orientation: an Euler sequence at its
    singularity, where two of its angles turn about one axis (3-1-3 at theta = 0, a body's default)."""
    try:
        check_regular(eqs, q, f"at t = {t:g} s")
    except SingularConfigurationError as exc:
        return f" Note: {exc}"
    return ""


def _speeds(problem, q: np.ndarray, values: dict, t: float, which: str, free: set | None) -> int:
    """Check the speed values at an end against ``G u + e = 0``; at ``t0`` also that they fix all speeds."""
    eqs = problem.eqs
    w0 = np.zeros(eqs.inputs.numel())
    G, e, _, _, _ = (np.asarray(x) for x in eqs.constraint_functions(q, np.zeros(eqs.nu), t, w0))
    G = G.reshape(eqs.nc, eqs.nu)
    names, S = rate_rows(eqs, q)
    given = [names.index(n) for n in values if n in names]
    A = np.vstack([G, S[given]])
    b = np.concatenate([-e.ravel(), [values[names[i]] for i in given]])
    u = np.linalg.lstsq(A, b, rcond=None)[0]
    r = A @ u - b
    if np.abs(r).max(initial=0.0) > VELOCITY_TOL * max(1.0, np.abs(b).max(initial=0.0)):
        culprits = [eqs.constraint_names[i] for i in range(eqs.nc) if abs(r[i]) > VELOCITY_TOL] or eqs.constraint_names
        raise ModelError(
            f"the {which} rates {_listing(values, names)} contradict constraint(s) {culprits}: no speeds satisfy "
            f"both (residual {np.abs(r).max():.3g} at t = {t:g} s); give fewer {which} rates and let the "
            f"constraints fix the rest")
    dof = eqs.nu - _rank(G)
    if free is not None:
        fixed = given + [names.index(n) for n in free if n in names]
        missing = _undetermined(np.vstack([G, S[fixed]]), eqs.model.speed_names)
        if missing:
            raise ModelError(
                f"initial speeds are not determined: no constraint and no initial value fixes {', '.join(missing)}; "
                f"IPOPT would have to choose them. Add initial rates (e.g. problem.initial({{'{missing[0]}': 0.0}}) "
                f"for a start at rest) or declare them free with problem.leave_free({missing})")
    return dof


# -- helpers ---------------------------------------------------------------------------------------
def _guess_at(problem, names: list[str], t: float) -> np.ndarray:
    """The guess of every coordinate at ``t``: the user's, else its initial (then final) value, else 0."""
    out = []
    for n in names:
        if n in problem.guess:
            out.append(float(np.broadcast_to(np.asarray(problem.guess[n](np.array([t])), float), (1,))[0]))
        else:
            out.append(problem.initial_values.get(n, problem.final_values.get(n, 0.0)))
    return np.array(out)


def _quaternion_spans(eqs) -> list[tuple[int, int]]:
    """``(first, end)`` of each unit quaternion's entries in ``q``."""
    spans, start = [], 0
    for b in eqs.bodies:
        n = b.q.numel()
        if isinstance(b.rotation, UnitQuaternion):
            spans.append((start + 3, start + n))
        start += n
    return spans


def unit_quaternions(eqs, q: np.ndarray) -> None:
    """In place: a quaternion of ``q`` left all zero (no value, no guess: the guess of an unset coordinate
    is 0) becomes the identity, a rotation; the zero quaternion is none (its least-squares steps are NaN:
    numpy's 'SVD did not converge' before this)."""
    for a, b in _quaternion_spans(eqs):
        if not np.linalg.norm(q[a:b]) > 1e-12:
            q[a:b] = np.r_[1.0, np.zeros(b - a - 1)]


def _quaternion_names(eqs) -> list[str]:
    names = eqs.model.coordinate_names
    return [names[i] for a, b in _quaternion_spans(eqs) for i in range(a, b)]


def _check_quaternion_ends(problem) -> None:
    """Given quaternions must be unit (the NLP holds their length at one: a longer one has no solution)."""
    eqs, names = problem.eqs, problem.eqs.model.coordinate_names
    for a, b in _quaternion_spans(eqs):
        comps = names[a:b]
        for which, values in (("initial", problem.initial_values), ("final", problem.final_values)):
            if not all(n in values for n in comps):
                continue
            q = np.array([values[n] for n in comps])
            if abs(np.linalg.norm(q) - 1.0) > 1e-8:
                raise ModelError(f"the {which} values of {', '.join(comps)} are not a unit quaternion (|q| = "
                                 f"{np.linalg.norm(q):.10g}); divide them by their length")
        if all(n in problem.initial_values and n in problem.final_values for n in comps):
            q0, qf = (np.array([values[n] for n in comps]) for values in (problem.initial_values, problem.final_values))
            if q0 @ qf < 0.0:
                # The NLP's quaternion path is continuous, so it ends at qf as given: on the other sheet from q0 that
                # is a full turn more than the motion to -qf, the same orientation (a sixth newcomer's rod on a ball
                # joint: objective 1.5005 against 1.4951, without a word).
                short = 2.0 * np.arccos(min(1.0, -float(q0 @ qf)))
                warnings.warn(f"the initial and final values of {', '.join(comps)} are on opposite sheets (q0 . qf = "
                              f"{q0 @ qf:.3g} < 0): qf and -qf are the same orientation, but the motion is solved to qf "
                              f"as given, which takes a rotation of at least {2 * np.pi - short:.3g} rad, where -qf "
                              f"takes at least {short:.3g} rad; give -qf if the shorter rotation is meant",
                              QuaternionSignWarning, stacklevel=_caller_level())


def _check_mirrored_poses(problem) -> None:
    """Warn where the initial or final values admit two poses (one quaternion parameter of a hinged body fixed: a
    seventh newcomer's URDF arm ended mirrored, at an objective below the pose asked for). Only for models with
    quaternions: an angle's value fixes its pose, and the check costs 2-60 ms on models of 1-10 bodies."""
    if any(isinstance(b.rotation, UnitQuaternion) for b in problem.eqs.bodies):
        for message in ambiguous_boundary_poses(problem):
            warnings.warn(message, AmbiguousPoseWarning, stacklevel=_caller_level())


def _caller_level() -> int:
    """The ``stacklevel`` of the first frame outside this package: a warning of the check points at the user's call
    (``problem.solve``, through any number of the package's own frames)."""
    package = __name__.split(".")[0]
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] == package:
        frame, level = frame.f_back, level + 1
    return level


def _quaternion_rows(eqs):
    """Rows fixing each unit quaternion's length (its scale is no degree of freedom)."""
    spans = _quaternion_spans(eqs)

    def rows(q):
        out = np.zeros((len(spans), eqs.nq))
        for k, (a, b) in enumerate(spans):
            out[k, a:b] = 2 * q[a:b]
        return out

    return rows


def _rank(A: np.ndarray) -> int:
    if not A.size:
        return 0
    s = np.linalg.svd(equilibrated(A)[0], compute_uv=False)
    return int((s > 1e-9 * max(1.0, s[0])).sum())


def _undetermined(rows: np.ndarray, names: list[str]) -> list[str]:
    """A smallest set of names whose values would fix the directions ``rows`` leaves free.

    The null space of ``rows`` holds the free directions; QR with column pivoting of its
    transpose picks one independent name per direction, the one that moves most.
    """
    scaled, cols = equilibrated(rows)
    _, s, vt = np.linalg.svd(scaled)
    rank = int((s > 1e-9 * max(1.0, s[0] if s.size else 1.0)).sum())
    Z = vt[rank:].T / cols[:, None]         # the free directions in the coordinates' own units
    if not Z.size:
        return []
    _, _, pivots = scipy.linalg.qr(Z.T, pivoting=True)
    chosen = sorted(pivots[: Z.shape[1]])
    return [names[i] for i in chosen]


def _listing(values: dict, names: list[str]) -> str:
    """The values among ``names``, as the user wrote them."""
    return "{" + ", ".join(f"{k!r}: {v:g}" for k, v in values.items() if k in names) + "}"


def _available_memory() -> float | None:
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        return None
    return None
