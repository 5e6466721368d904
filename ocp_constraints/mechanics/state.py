"""Consistent initial states: coordinates checked against the constraints, speeds solved.

A user gives every coordinate and *some* rates (coordinate rates such as
``disk.psi_dot`` or speeds such as ``disk.vbar_x``); the remaining speeds follow from
the constraints ``G u + e = 0``. Where the constraints leave freedom, the rates the
user did not mention are made as small as possible (zero when they can be).
"""
from __future__ import annotations

import numpy as np

from .equations import SystemEquations
from .fast_eval import Buffered
from ..errors import InconsistentStateError, ModelError
from .rotations import UnitQuaternion
from .validate import check_constraint_values, input_values

POSITION_TOL = 1e-9
VELOCITY_TOL = 1e-9


_MARGINS: dict[tuple, object] = {}


def margin_function(rotation):
    """``r -> margin`` of a body's rotation parameters (a CasADi Function): ``|g_1 . (g_2 x g_3)|``
    of an Euler sequence (its graph depends on the axes only, so it is built once per sequence), a
    quaternion's norm. The body is singular where the margin falls below the rotation's tolerance."""
    import casadi as ca

    key = ("quaternion",) if isinstance(rotation, UnitQuaternion) else ("euler", rotation.axes)
    if key not in _MARGINS:
        r = ca.SX.sym("r", rotation.n_parameters)
        value = ca.norm_2(r) if key[0] == "quaternion" else ca.fabs(rotation.basis_volume(r))
        _MARGINS[key] = ca.Function("margin_" + "_".join(key), [r], [value])
    return _MARGINS[key]


def check_regular(eqs: SystemEquations, q: np.ndarray, where: str) -> None:
    """Every body's rotation away from its singularity at ``q``: the margins of :func:`margin_function`
    evaluated numerically, the body's own check (and message) only for a body below its tolerance."""
    start = 0
    for b in eqs.bodies:
        n = b.q.numel()
        r = np.asarray(q[start + 3:start + n], dtype=float)
        tol = 1e-12 if isinstance(b.rotation, UnitQuaternion) else b.rotation.singularity_tolerance
        if not float(margin_function(b.rotation)(r)) >= tol:   # NaN too
            b.check_singularity(q[start:start + n], where)
        start += n


def coordinate_vector(eqs: SystemEquations, coordinates: dict[str, float]) -> np.ndarray:
    """Coordinates in model order from a name -> value map (every coordinate required)."""
    names = eqs.model.coordinate_names
    unknown = sorted(set(coordinates) - set(names))
    if unknown:
        raise ModelError(f"unknown coordinate(s) {unknown}; the model's coordinates are {names}")
    missing = [n for n in names if n not in coordinates]
    if missing:
        raise ModelError(f"initial coordinates missing for {missing}")
    q = np.array([float(coordinates[n]) for n in names])
    bad = [n for n, v in zip(names, q) if not np.isfinite(v)]
    if bad:
        raise ModelError(f"initial coordinate(s) {bad} are not finite")
    return q


def rate_rows(eqs: SystemEquations, q: np.ndarray) -> tuple[list[str], np.ndarray]:
    """Names and rows ``S`` such that ``S u`` gives each named rate at ``q``.

    Names are the coordinate rates ``<body>.<coordinate>_dot`` and the speeds
    ``<body>.vbar_x`` ... ``<body>.omega_z``.
    """
    N = np.asarray(eqs.rate_matrix(q))
    names = [f"{n}_dot" for n in eqs.model.coordinate_names] + eqs.model.speed_names
    return names, np.vstack([N, np.eye(eqs.nu)])


def _check_position_forms(eqs: SystemEquations, q: np.ndarray, t0: float, inputs: np.ndarray) -> None:
    """Each position form ``phi`` must have ``d(phi)/dt = pi`` (checked at ``q`` for random speeds)."""
    if not eqs.holonomic:
        return
    # Three generic speed vectors (fixed, irrational steps; no numpy.random, 25-40 ms of import for this).
    for k in range(3):
        u = 1.5 * np.sin(12.9898 * (k + 1) + 78.233 * np.arange(1, eqs.nu + 1))
        mismatch = np.asarray(eqs.position_form_mismatch(q, u, t0, inputs)).ravel()
        for k, i in enumerate(eqs.holonomic):
            if abs(mismatch[k]) > 1e-7 * (1 + np.abs(u).max()):
                raise ModelError(
                    f"the position form of constraint '{eqs.constraint_names[i]}' does not match the "
                    f"constraint: d(phi)/dt - pi = {mismatch[k]:.3g} at the initial state. phi(q, t) must "
                    "be the time integral of pi (check its sign and scale), or leave it out."
                )


def consistent_state(eqs: SystemEquations, coordinates: dict[str, float], rates: dict[str, float], t0: float = 0.0,
                     inputs=None) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(q0, u0)`` satisfying every constraint at ``t0`` (with ``inputs`` at ``t0``, default zero).

    Raises :class:`InconsistentStateError` naming the constraint that the coordinates
    violate, or the given rates that contradict the constraints, and
    :class:`RedundantConstraintsError` if constraints repeat each other.
    """
    q = coordinate_vector(eqs, coordinates)
    inputs = input_values(eqs, inputs, t0)
    check_regular(eqs, q, f"at t = {t0:g}")
    G, e, phi, _, _ = (np.asarray(x) for x in eqs.constraint_functions(q, np.zeros(eqs.nu), t0, inputs))
    check_constraint_values(eqs, G, e, phi)
    phi = phi.ravel()
    for k, i in enumerate(eqs.holonomic):
        if abs(phi[k]) > POSITION_TOL:
            raise InconsistentStateError(
                f"initial coordinates violate constraint '{eqs.constraint_names[i]}' at position "
                f"level: residual {phi[k]:.3g} (tolerance {POSITION_TOL:g}). Fix the initial "
                "coordinates (e.g. the height of a body in contact)."
            )
    _check_position_forms(eqs, q, t0, inputs)
    eqs.check_redundancy(q, t0)
    names, S = rate_rows(eqs, q)
    unknown = sorted(set(rates) - set(names))
    if unknown:
        raise ModelError(f"unknown rate(s) {unknown}; valid names: {names}")
    given = [names.index(n) for n in rates]
    values = np.array([float(rates[n]) for n in rates])
    if not np.all(np.isfinite(values)):
        raise ModelError(f"initial rates must be finite, got {rates}")
    A = np.vstack([G, S[given]]) if given else G
    b = np.concatenate([-e.ravel(), values])
    u, *_ = np.linalg.lstsq(A, b, rcond=None)
    residual = A @ u - b
    if np.abs(residual).max(initial=0.0) > VELOCITY_TOL * max(1.0, np.abs(b).max(initial=0.0)):
        bad = [eqs.constraint_names[i] for i in range(eqs.nc) if abs(residual[i]) > VELOCITY_TOL]
        raise InconsistentStateError(
            f"the given initial rates {sorted(rates)} contradict the constraints "
            f"{bad or eqs.constraint_names}: no speeds satisfy both (residual "
            f"{np.abs(residual).max():.3g}). Give fewer rates and let the constraints fix the rest."
        )
    Z = null_space(A)
    if Z.size:
        mentioned = set(given)
        rest = [i for i in range(len(names) - eqs.nu) if i not in mentioned]
        R = S[rest]
        w, *_ = np.linalg.lstsq(R @ Z, -R @ u, rcond=None)
        u = u + Z @ w
    # What was checked here, for the simulation's preflight not to check the same values again.
    eqs.__dict__["_checked_start"] = (q.copy(), u.copy(), float(t0), np.array(inputs, dtype=float), G)
    return q, u


def checked_start(eqs: SystemEquations, q: np.ndarray, u: np.ndarray, t0: float, inputs) -> np.ndarray | None:
    """``G`` at ``(q, u, t0, inputs)`` if :func:`consistent_state` returned exactly this state of ``eqs``
    (its coordinates regular and on the constraints, its speeds satisfying them, no constraint
    redundant: checked there), else None."""
    known = eqs.__dict__.get("_checked_start")
    if known is None:
        return None
    kq, ku, kt, kw, G = known
    same = (float(t0) == kt and np.array_equal(q, kq) and np.array_equal(u, ku)
            and np.array_equal(np.asarray(inputs, dtype=float).ravel(), kw.ravel()))
    return G if same else None


def projection_parts(eqs: SystemEquations) -> Buffered:
    """``(q, u, t, inputs) -> (phi, d(phi)/dq, G, G u + e, M)``: what a projection needs, in one call
    (built once per model, or given by an equal model's simulation: a call from Python costs more
    than evaluating these small functions, and building one ~1 ms)."""
    cache = eqs.__dict__
    if "_projection_parts" not in cache:
        import casadi as ca

        cache["_projection_parts"] = Buffered(ca.Function(
            "projection_parts", [eqs.q, eqs.u, eqs.t, eqs.inputs],
            [eqs.phi, ca.jacobian(eqs.phi, eqs.q), eqs.G, eqs.G @ eqs.u + eqs.e, eqs.mass_matrix]))
    return cache["_projection_parts"]


def _project(eqs: SystemEquations, q: np.ndarray, u: np.ndarray | None, t: float, inputs, iterations: int = 8):
    """Gauss-Newton onto ``phi(q, t) = 0`` (and unit quaternions), then the speeds onto ``G u + e = 0``
    in the kinetic-energy metric (if ``u`` is given). Returns ``(q, u, drift_q, drift_u)``, the drifts
    being ``max |phi|`` and ``max |G u + e|`` of the state given."""
    q = np.array(q, dtype=float)
    u_in = np.zeros(eqs.nu) if u is None else np.asarray(u, dtype=float)
    spans, start = [], 0
    for b in eqs.bodies:
        n = b.q.numel()
        if isinstance(b.rotation, UnitQuaternion):
            spans.append(slice(start + 3, start + n))
        start += n
    w = np.zeros(eqs.inputs.numel()) if inputs is None else inputs
    parts = projection_parts(eqs)

    def evaluate(qv):
        phi, J, G, pi, M = parts(qv, u_in, t, w)
        return phi, J.reshape(-1, eqs.nq), G.reshape(-1, eqs.nu), pi, M

    def residual(qv, phi, J):
        if not spans:
            return phi, J
        rows, res = [J], [phi]
        for s in spans:
            row = np.zeros((1, eqs.nq))
            row[0, s] = 2 * qv[s]
            rows.append(row)
            res.append([qv[s] @ qv[s] - 1.0])
        return np.concatenate(res), np.vstack(rows)

    values = evaluate(q)
    drift_q, drift_u = float(np.abs(values[0]).max(initial=0.0)), float(np.abs(values[3]).max(initial=0.0))
    if iterations and spans:
        for s in spans:
            q[s] /= np.linalg.norm(q[s])
        values = evaluate(q)
    if eqs.holonomic and iterations:
        best = None
        for _ in range(iterations):
            r, A = residual(q, values[0], values[1])
            size = float(np.abs(r).max())
            if best is not None and size >= best[0] and best[0] < 1e-10:
                q, values = best[1], best[2]   # no progress near the solution: round-off, keep the better state
                break
            best = (size, q, values)
            if size < 1e-15:
                break
            q = q - np.linalg.lstsq(A, r, rcond=None)[0]
            values = evaluate(q)
    if u is None or not eqs.nc:
        return q, u_in.copy(), drift_q, drift_u
    _, _, G, r, M = values
    n = eqs.nu
    K = np.zeros((n + eqs.nc, n + eqs.nc))   # [M, G^T; G, 0]
    K[:n, :n], K[:n, n:], K[n:, :n] = M, G.T, G
    rhs = np.zeros(n + eqs.nc)
    rhs[n:] = -r
    try:
        u_new = u_in + np.linalg.solve(K, rhs)[:n]
    except np.linalg.LinAlgError:
        eqs.check_redundancy(q, t)      # names the constraints that repeat others, if that is why
        raise ModelError(f"model '{eqs.model.name}': the speeds cannot be projected onto the constraints at t = {t:g} s "
                         f"(the matrix [M, G^T; G, 0] is singular: a body without mass or inertia in a direction no "
                         f"constraint holds, or a singular configuration of the constraints)") from None
    return q, u_new, drift_q, drift_u


def project_positions(eqs: SystemEquations, q: np.ndarray, t: float, iterations: int = 8, inputs=None) -> np.ndarray:
    """Nearest coordinates on ``phi(q, t) = 0`` with unit quaternions (Gauss-Newton, minimum-norm steps).

    A quaternion's length is one more equation of the Newton steps (``|q|^2 - 1 = 0``), so the
    result is on the constraints *and* unit: normalizing after the steps would leave ``phi``
    violated, normalizing only before them leaves ``|q| != 1`` (and ``Phi = lambda A`` scaled
    by ``|q|^2``). The steps stop at ``max |residual| < 1e-15``, or where a step no longer
    lowers a residual already below 1e-10 (round-off), keeping the better of the last two.
    """
    return _project(eqs, q, None, t, inputs, iterations)[0]


def project_speeds(eqs: SystemEquations, q: np.ndarray, u: np.ndarray, t: float, inputs=None) -> np.ndarray:
    """Speeds nearest to ``u`` in the kinetic-energy metric with ``G u + e = 0``.

    Solved through the KKT matrix ``[M, G^T; G, 0]`` (``M`` may be singular for a thin rod).
    """
    if not eqs.nc:
        return np.array(u, dtype=float)
    return _project(eqs, q, u, t, inputs, iterations=0)[1]


def project_state(eqs: SystemEquations, q: np.ndarray, u: np.ndarray, t: float, inputs=None) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Project ``(q, u)`` onto the constraint manifold; also return the sizes of the corrections."""
    q_new, u_new, _, _ = _project(eqs, q, u, t, inputs)
    return q_new, u_new, float(np.linalg.norm(q_new - q)), float(np.linalg.norm(u_new - u))


def project_with_drift(eqs: SystemEquations, q: np.ndarray, u: np.ndarray, t: float, inputs=None) -> tuple[np.ndarray, np.ndarray, float, float]:
    """:func:`project_state`, returning instead the drifts of the given state: ``max |phi(q, t)|``
    and ``max |G u + e|`` (what the integrator let the state drift by, the projection removes)."""
    return _project(eqs, q, u, t, inputs)


def null_space(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the null space of ``A`` (columns), by SVD as scipy.linalg.null_space
    does; here so that simulation does not import scipy.linalg (0.7 s) for it."""
    A = np.atleast_2d(A)
    if not A.size:
        return np.eye(A.shape[1])
    _, s, vt = np.linalg.svd(A, full_matrices=True)
    tol = max(A.shape) * np.finfo(float).eps * (s.max() if s.size else 0.0)
    return vt[int((s > tol).sum()):].T
