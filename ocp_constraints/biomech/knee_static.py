"""Minimum-effort knee contact loads by static optimisation (issue 7, step 3).

Per frame of a gait trial, with the generalized forces ``Q`` of the leg's coordinates
from our inverse dynamics (:func:`ocp_constraints.biomech.gait.run_inverse_dynamics`, paper eqs.
38-44: a locked knee direction's ``Q`` is its multiplier), the unknowns are the muscle
activations ``a`` (tension ``F_m = a_m F0_m + Fp_m``: ideal force generators with
``F0`` = the model's ``max_isometric_force`` and no passive force, or Hill-type muscles
with rigid tendons, :mod:`.knee_hill`, where ``F0`` is the force at full activation at the
frame's fibre length and velocity and ``Fp`` the passive force), the multipliers ``lambda`` of the knee constraints of
the two-body knee (:mod:`.knee_model`) (``N_medial``, ``N_lateral``, ``ap``, ``ml``, ``ie``) and reserve
torques ``rho`` (N m) on the primary coordinates. The leg's Newton-Euler equations,
projected on the coordinates (eqs. 35-41), read

    Q_c = sum_m r_mc F0_m a_m + sum_j lambda_j A_jc + rho_c

for c in hip_flexion/adduction/rotation, knee_flexion (plus the coupled patella's
``Q``), ankle_angle, subtalar_angle (with reserves) and the five locked knee directions
(no reserve). ``r = -dL/dq`` from :mod:`.knee_muscles`; ``A = G dU/dp`` of the knee
constraints in the JW knee coordinates (eq. 39). Minimise ``sum a^2 + w sum rho^2``
subject to ``0 <= a <= 1``, ``N_medial >= 0``, ``N_lateral >= 0``: one sparse NLP over
all frames (IPOPT through ``casadi.nlpsol``), built once per trial.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..dynamics.result import Result
from ..errors import KneeError, KneeSolveError
from ..ocp.solver_threads import ipopt_solver
from ..output.signals import call_interruptibly
from .knee_contact import KNEE_COORDINATES
from .knee_model import CONTACT
from .knee_muscles import PRIMARY, SECONDARY, MusclePaths

RESERVED = ["hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "ankle_angle", "subtalar_angle"]
RESERVE_WEIGHT = 1.0       # cost of 1 N m of reserve = cost of one fully active muscle
LOAD_SCALE = 1000.0        # N: unit of the contact multipliers and of the balance rows inside the NLP
# How IPOPT's MUMPS factorizes the KKT matrix, here and in the collocation (:mod:`.knee_collocation`, most of
# whose solve it is). None of these changes a step beyond rounding (the same iterates: static loads to 5e-15 BW,
# collocation objective to 2e-16 and loads to 1.5e-15 BW, on ngait_og5, bouncy7, mtpgait3):
# - mumps_mem_percent 100: workspace 2x MUMPS's estimate, not 11x (IPOPT's 1000): the 88 MB the collocation
#   allocated, and the kernel zeroed, per factorization made 0.7 s of system time; IPOPT doubles it and refactors
#   if MUMPS needs more;
# - mumps_permuting_scaling 0 with pivot_order 2 (AMF): no weighted-matching pairs constrain the ordering, which
#   then needs 2.7e7 instead of 4.1e7 operations per collocation factorization (MUMPS's estimate);
# - min_refinement_steps 0: a refinement solve only when the residual asks for it (IPOPT's default: always one).
# Collocation solve 6.7 -> 4.3 s CPU, static 0.24 -> 0.16 s (ngait_og5, loaded machine):
# python scripts/knee_collocation_kkt.py
KKT_OPTIONS = {"ipopt.mumps_mem_percent": 100, "ipopt.mumps_permuting_scaling": 0, "ipopt.mumps_pivot_order": 2,
               "ipopt.min_refinement_steps": 0}


def _balance_residual(Qc, R, A, force, lam, rho) -> float:
    """Largest residual (N m or N) of ``Q_c = R F + A^T lambda + rho`` over all frames and rows."""
    res = np.einsum("ncm,nm->nc", R, force) + np.einsum("njc,nj->nc", A, lam) - Qc
    res[:, :rho.shape[1]] += rho
    return float(np.abs(res).max())


def _block_diagonal(blocks: np.ndarray) -> ca.DM:
    """Sparse ``diag(blocks[0], blocks[1], ...)`` (frames x rows x cols) as a CasADi matrix, compressed
    columns built in NumPy (no SciPy import: 0.4 s of CPU at start-up)."""
    N, nr, nc = blocks.shape
    n, i, j = np.nonzero(blocks)
    rows, cols, vals = n * nr + i, n * nc + j, blocks[n, i, j]
    order = np.lexsort((rows, cols))                  # column-major, rows ascending within a column
    indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=N * nc))])
    sparsity = ca.Sparsity(N * nr, N * nc, indptr.tolist(), rows[order].tolist())
    return ca.DM(sparsity, vals[order])


@dataclass
class StaticResult(Result):
    """Per frame: ``lam`` (frames x 5, N or N m), activations, muscle forces (N), reserves (N m).

    The common vocabulary (:mod:`ocp_constraints.dynamics.result`): ``success`` and
    ``status`` are IPOPT's; ``sample(name)`` over :meth:`sample_columns` (the columns of
    the knee's loads.csv). It holds multipliers, not joint loads at body states, so
    ``loads()`` and ``load_about()`` raise a :class:`ModelError` that says so.
    """

    t: np.ndarray
    muscles: list[str]
    activation: np.ndarray
    force: np.ndarray
    lam: np.ndarray
    reserve: np.ndarray
    residual: float
    status: str
    timings: dict[str, float] = field(default_factory=dict)
    success: bool = True
    fallback: str | None = None     # why these are the static loads where another method was asked (collocation)

    def sample_columns(self) -> dict[str, np.ndarray]:
        """``N_medial``, ``N_lateral``, ``N_total`` (N), ``<constraint>.lambda`` of the knee constraints,
        ``<muscle>.force`` (N), ``reserve_<coordinate>`` (N m), ``<muscle>.activation`` (and, for
        collocation, ``<muscle>.excitation``): the knee's loads.csv columns, in their order."""
        cols = {"N_medial": self.medial, "N_lateral": self.lateral, "N_total": self.total}
        cols.update({f"{c}.lambda": self.lam[:, j] for j, c in enumerate(CONTACT)})
        cols.update({f"{m}.force": self.force[:, i] for i, m in enumerate(self.muscles)})
        cols.update({f"reserve_{c}": self.reserve[:, i] for i, c in enumerate(RESERVED)})
        excitation = getattr(self, "excitation", None)
        for i, m in enumerate(self.muscles):
            cols[f"{m}.activation"] = self.activation[:, i]
            if excitation is not None:
                cols[f"{m}.excitation"] = excitation[:, i]
        return cols

    @property
    def medial(self) -> np.ndarray:
        return self.lam[:, 0]

    @property
    def lateral(self) -> np.ndarray:
        return self.lam[:, 1]

    @property
    def total(self) -> np.ndarray:
        return self.lam[:, 0] + self.lam[:, 1]


def frame_data(gait, paths: MusclePaths, contact_A: ca.Function):
    """Right-hand sides ``Q`` (frames x 11), moment arms (frames x 11 x muscles) and ``A`` (frames x 5 x 11)."""
    names = gait.coordinate_names
    missing = [c for c in PRIMARY + SECONDARY if c not in names]
    if missing:
        raise KneeError(f"{gait.osim.path}: the model has no coordinate(s) {missing} (a JW-type knee model is needed)")
    P = gait.states["p"]
    rows = RESERVED + SECONDARY
    Qc = np.column_stack([gait.generalized_force(c) for c in rows])
    if "patfem_flexion" in names:             # coupled patella: patfem_flexion = knee_flexion + const
        Qc[:, rows.index("knee_flexion")] += gait.generalized_force("patfem_flexion")
    qv = np.column_stack([P[:, names.index(c)] for c in paths.coordinates])
    N = len(gait.t)
    R = paths.moment_arms_at(qv)              # frames x coordinates(paths order) x muscles
    idx = [paths.coordinates.index(c) for c in rows]
    R = R[:, idx, :]
    pk = np.column_stack([P[:, names.index(c)] for c in KNEE_COORDINATES])
    A6 = np.asarray(contact_A.map(N)(pk.T)).reshape(5, N, 6).transpose(1, 0, 2)
    A = np.zeros((N, 5, len(rows)))
    for k, c in enumerate(KNEE_COORDINATES):
        A[:, :, rows.index(c)] = A6[:, :, k]
    return Qc, R, A


def muscle_kinematics(gait, paths: MusclePaths) -> tuple[np.ndarray, np.ndarray]:
    """Muscle-tendon-unit lengths ``L`` (m) and rates ``dL/dt`` (m/s), frames x muscles.

    The lengths of the units the Hill parameters describe (:attr:`MusclePaths.unit_length`:
    for the quadriceps the path ending on the patella, not the force path over the
    patellar ligament to the tibia); for the other muscles ``dL/dt = -R qdot``.
    """
    names = gait.coordinate_names
    P, Pd = gait.states["p"], gait.states["pdot"]
    qv = np.column_stack([P[:, names.index(c)] for c in paths.coordinates])
    qd = np.column_stack([Pd[:, names.index(c)] for c in paths.coordinates])
    N = len(gait.t)
    L = np.asarray(paths.unit_length.map(N)(qv.T)).T
    Jl = np.asarray(paths.unit_jacobian.map(N)(qv.T)).reshape(len(paths.muscles), N, -1).transpose(1, 0, 2)
    return L, np.einsum("nmc,nc->nm", Jl, qd)


def reserve_weights_from_sigma(sigma: dict[str, float]) -> np.ndarray:
    """Reserve weights (per (N m)^2, one per :data:`RESERVED` row) from the uncertainty ``sigma`` (N m) of the
    inverse dynamics' ``Q`` on the rows named; the other rows keep :data:`RESERVE_WEIGHT`.

    The effort ``sum a^2`` read as the negative log of the activations' prior and ``Q_c`` as a measurement with a
    Gaussian error of standard deviation ``sigma_c`` (the balance of eqs. 35-41 holds up to that error, the reserve
    ``rho_c``) make ``sum a^2 + sum_c rho_c^2 / (2 sigma_c^2)`` the negative log-posterior: ``w_c = 1/(2 sigma_c^2)``.
    The uniform ``RESERVE_WEIGHT = 1`` is ``sigma = 0.71 N m`` (issue 15, candidate C18,
    ``results/knee/preregistration.md``, sixth round).
    """
    w = np.full(len(RESERVED), RESERVE_WEIGHT)
    for name, value in sigma.items():
        if name not in RESERVED:
            raise KneeError(f"reserve uncertainty for '{name}': no reserve on that coordinate "
                            f"(use one of {', '.join(RESERVED)})")
        s = float(value)
        if not (np.isfinite(s) and s > 0.0):
            raise KneeError(f"reserve uncertainty for '{name}' = {value!r}: a standard deviation must be a finite "
                            f"number > 0 (N m)")
        w[RESERVED.index(name)] = 1.0 / (2.0 * s * s)
    return w


def reserve_weight_rows(reserve_weight, N: int) -> np.ndarray:
    """The reserves' weights (per (N m)^2) as a :data:`RESERVED` x ``N`` frames array: ``reserve_weight`` is one
    finite weight > 0, one per reserved row, or one per frame and row (frames x rows; issue 15, C19:
    :func:`.knee_id_uncertainty.reserve_weights_per_frame`)."""
    nres = len(RESERVED)
    w_res = np.asarray(reserve_weight, float)
    if w_res.shape not in ((), (1,), (nres,), (N, nres)) or not np.all(np.isfinite(w_res) & (w_res > 0)):
        raise KneeError(f"reserve_weight {reserve_weight!r}: one finite weight > 0, one per reserved coordinate "
                        f"({', '.join(RESERVED)}), or one per frame and reserved coordinate ({N} x {nres})")
    return w_res.T if w_res.ndim == 2 else np.broadcast_to(w_res.reshape(-1, 1), (nres, N))


def solve_static(t, Qc, R, A, F0, muscles_on: bool = True, contact_nonnegative: bool = True,
                 reserve_weight=RESERVE_WEIGHT, passive=None) -> StaticResult:
    """All frames in one NLP (IPOPT): see the module docstring. ``Qc`` in N m / N.

    ``reserve_weight``: the cost of the reserves per (N m)^2, one number for all of them, one per
    :data:`RESERVED` row (e.g. :func:`reserve_weights_from_sigma`) or one per frame and row
    (:func:`reserve_weight_rows`).

    Muscle tension ``F = a F0 + passive``: ``F0`` (N) per muscle (ideal force generators,
    the model's max isometric force) or per frame and muscle (the Hill force at full
    activation, :func:`ocp_constraints.biomech.knee_hill.hill_forces`); ``passive`` (frames x
    muscles, N) the passive fibre force (default none).
    """
    clock = time.perf_counter()
    N, nr, nm = R.shape
    F0 = np.broadcast_to(np.asarray(F0, float), (N, nm))
    passive = np.zeros((N, nm)) if passive is None else np.asarray(passive, float)
    nres = len(RESERVED)
    nx = nm + 5 + nres
    # the balances are linear in x = (a, lambda/LOAD_SCALE, rho) per frame: one constant sparse block per
    # frame, and rows divided by LOAD_SCALE, so that IPOPT sees unknowns and residuals of order one
    # (39 iterations instead of 220 on ngait_og5; the optimum is the same)
    Bn = np.zeros((N, nr, nx))
    Bn[:, :, :nm] = R * F0[:, None, :]
    Bn[:, :, nm:nm + 5] = A.transpose(0, 2, 1) * LOAD_SCALE
    Bn[:, :nres, nm + 5:] = np.eye(nres)
    B = _block_diagonal(Bn / LOAD_SCALE)
    rhs = ((Qc - np.einsum("ncm,nm->nc", R, passive)) / LOAD_SCALE).ravel()
    # effort sum a^2 + w sum rho^2 as one weighted dot product over all frames (frame-major x): a mapped
    # per-frame Function gave the same optimum with 0.1 s more CPU to build (ngait_og5)
    weights = np.zeros((nx, N))
    weights[:nm], weights[nm + 5:] = 1.0, reserve_weight_rows(reserve_weight, N)
    X = ca.MX.sym("X", nx * N)
    nlp = {"x": X, "f": ca.dot(ca.DM(weights.ravel(order="F")), X * X), "g": ca.mtimes(B, X) - ca.DM(rhs)}
    # a convex QP (quadratic effort, linear balances, bounds): Mehrotra's predictor-corrector, which IPOPT
    # recommends for convex QPs, takes 16 iterations instead of 39 (ngait_og5; the same loads to 1e-3 N)
    solver = ipopt_solver("knee_so", nlp, {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
                                            "ipopt.tol": 1e-8, "ipopt.hessian_constant": "yes",
                                            "ipopt.jac_c_constant": "yes", "ipopt.jac_d_constant": "yes",
                                            "ipopt.mehrotra_algorithm": "yes", "ipopt.bound_relax_factor": 0.0,
                                            **KKT_OPTIONS})
    built = time.perf_counter()
    lbx, ubx = np.full((nx, N), -np.inf), np.full((nx, N), np.inf)
    lbx[:nm], ubx[:nm] = 0.0, (1.0 if muscles_on else 0.0)
    if contact_nonnegative:
        lbx[nm:nm + 2] = 0.0
    x0 = np.zeros((nx, N))
    x0[:nm] = 0.05 if muscles_on else 0.0
    sol = call_interruptibly(solver, x0=x0.ravel(order="F"), lbx=lbx.ravel(order="F"),
                             ubx=ubx.ravel(order="F"), lbg=0, ubg=0)   # Ctrl-C: RunInterrupted, not a failure
    status = solver.stats()["return_status"]
    Xs = np.asarray(sol["x"]).reshape(nx, N, order="F")
    Xs[nm:nm + 5] *= LOAD_SCALE
    g = _balance_residual(Qc, R, A, Xs[:nm].T * F0 + passive, Xs[nm:nm + 5].T, Xs[nm + 5:].T)
    done = time.perf_counter()
    act = Xs[:nm].T
    result = StaticResult(np.asarray(t), [], act, act * F0 + passive, Xs[nm:nm + 5].T, Xs[nm + 5:].T, float(g), status,
                          {"build": built - clock, "solve": done - built}, success=bool(solver.stats()["success"]))
    if not result.success:      # the last iterate goes with the error: a failed run keeps what it had
        raise KneeSolveError(f"static optimisation failed: IPOPT status '{status}', max equation residual {g:.3g}",
                             result)
    return result
