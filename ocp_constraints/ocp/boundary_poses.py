"""Boundary values that leave a pose two-fold: a mirrored pose that IPOPT picks without a word.

A unit quaternion ``(qw, qx, qy, qz)`` has four parameters for three rotational degrees of freedom; its unit
length (held by the transcription as one of ``SystemEquations.position_rows``, not by ``phi``) and the joints'
holonomic constraints ``phi(q) = 0`` fix the rest. Those rows are quadratic, so fixing *some* parameters can leave
the others determined only up to a sign: a hinge body about ``E3`` is ``(cos theta/2, 0, 0, sin theta/2)``, and
``qw = cos(theta/2)`` alone admits ``theta`` and ``-theta``. Locally (the rank of the Jacobian) the end looks fixed,
so no rank test sees it; the NLP lands in either pose depending on its start (a two-link arm ended with its elbow
mirrored, at a lower objective than the pose asked for). ``q`` and ``-q`` are one rotation: no ambiguity.

:func:`ambiguous_boundary_poses` finds such ends numerically: Gauss-Newton on ``position_rows = 0`` with the fixed
coordinates held, from a few starts (the guess, a consistent configuration, and their copies with one body's unfixed
quaternion parameters negated), and compares the converged poses' rotation matrices.
"""
from __future__ import annotations

import functools
import itertools

import numpy as np

from ..mechanics.fast_eval import Buffered
from ..mechanics.rotations import UnitQuaternion

CONVERGED = 1e-10      # max |residual| of a configuration kept as a solution
SAME_ROTATION = 1e-6   # max |R1 - R2| below which two rotation matrices are one rotation


def ambiguous_boundary_poses(problem) -> list[str]:
    """One message per end (``"initial"``, ``"final"``) whose fixed coordinate values admit configurations on the
    constraints (``phi = 0``, unit quaternions) that turn some body differently, each rotation locally determined (a
    continuum, a pose left free on purpose, is not reported); ``[]`` if none, or if nothing is fixed there."""
    ends = (("initial", problem.initial_values, 0.0), ("final", problem.final_values, float(problem.t_final)))
    return [m for which, values, t in ends if (m := _end(problem, which, values, t))]


class _Rows:
    """``position_rows`` of a model at one time and inputs: residual, Jacobian (dense) and every body's ``vec(Q)``."""

    def __init__(self, eqs, t: float, w: np.ndarray):
        cache = eqs.__dict__.get("_boundary_poses")
        if cache is None:           # built once per model's equations (~20 ms for ten bodies: the Jacobian)
            import casadi as ca

            rows, R = eqs.position_rows, ca.vertcat(*[ca.vec(b.Q) for b in eqs.bodies])
            cache = eqs.__dict__["_boundary_poses"] = {"starts": {}, "parts": Buffered(ca.Function(
                "boundary_pose_parts", [eqs.q, eqs.t, eqs.inputs], [rows, ca.densify(ca.jacobian(rows, eqs.q)), R]))}
        parts, self.w, self.starts = cache["parts"], w, cache["starts"]
        self.at = lambda q: parts(q, t, w)
        # (name, first, end, is a quaternion) of each body's rotation parameters in q (after its 3 position ones)
        self.bodies = [(b.name, int(e - b.q.numel() + 3), int(e), isinstance(b.rotation, UnitQuaternion))
                       for b, e in zip(eqs.bodies, np.cumsum([b.q.numel() for b in eqs.bodies]))]
        self.turning = np.isin(np.arange(eqs.nq), [k for _, a, b, _ in self.bodies for k in range(a, b)])

    def solve(self, q: np.ndarray, free: np.ndarray, steps: int = 30,
              soft: tuple | None = None) -> tuple[np.ndarray, float, np.ndarray]:
        """Gauss-Newton onto the rows, only ``free`` moving: ``q``, its ``max |residual|`` and rotation matrices (one
        row each); ``soft = (fixed, target)`` adds the rows ``q[fixed] = target``."""
        q, sizes = q.copy(), []
        for _ in range(steps):
            r, J, R = self.at(q)
            if soft is not None:
                r, J = np.r_[r, q[soft[0]] - soft[1]], np.vstack([J, np.eye(len(q))[soft[0]]])
            sizes.append(float(np.abs(r).max(initial=0.0)))
            # Converged, or stalled (not halved in three steps: no pose near this start, e.g. a mirror the other fixed
            # values forbid; such starts took most of the time at 30 steps each).
            if sizes[-1] < CONVERGED or not free.any() or (len(sizes) > 3 and sizes[-1] > 0.5 * sizes[-4]):
                return q, sizes[-1], R.reshape(-1, 9)
            A = J[:, free]
            # Minimum-norm step by the smaller normal equations, damped by a vanishing Levenberg-Marquardt term where
            # the rows leave directions free; an SVD (lstsq) took 3x as long, and this runs before every solve.
            wide = A.shape[0] < A.shape[1]
            N = A @ A.T if wide else A.T @ A
            N.flat[:: N.shape[0] + 1] += 1e-10 * max(float(N.diagonal().max(initial=0.0)), 1e-300)
            step = A.T @ np.linalg.solve(N, r) if wide else np.linalg.solve(N, A.T @ r)
            # Rotation parameters by at most 0.5 a step: a long step could jump past the pose nearest the start, and
            # that nearness is what the starts are chosen for (positions enter linearly: not limited).
            q[free] -= step * min(1.0, 0.5 / max(np.abs(step[self.turning[free]]).max(initial=0.0), 1e-300))
        return q, np.inf, np.zeros((len(self.bodies), 9))       # out of steps

    def onto(self, base: np.ndarray, fixed: np.ndarray, target: np.ndarray, far: bool):
        """``base`` moved onto the fixed values: held there at once, else (``far``) reached as rows of their own with
        every coordinate free, then held. A ten-link 3D chain's generic pose reached set_boundary's values of random
        joint angles (+-2 rad) at 6 of 24 ends at once, 12 so (11 by continuation in four stages of the values)."""
        found = self.solve(self.insert(base, fixed, target), ~fixed, 12)
        if found[1] < CONVERGED or not far:
            return found
        q = self.solve(base, np.ones(len(base), bool), soft=(fixed, target))[0]
        return self.solve(self.insert(q, fixed, target), ~fixed)

    def insert(self, q: np.ndarray, fixed: np.ndarray, target: np.ndarray) -> np.ndarray:
        """``q`` with the fixed coordinates at ``target``, each quaternion's unfixed parameters rescaled to unit
        length (their signs kept: the start stays on its side of every mirror)."""
        q = q.copy()
        q[fixed] = target
        for _, a, b, quaternion in self.bodies:
            if quaternion:
                if not np.linalg.norm(q[a:b]) > 1e-12:
                    q[a:b] = [1.0, 0.0, 0.0, 0.0]       # no rotation at all: the identity instead
                loose = ~fixed[a:b]
                room, size = 1.0 - np.sum(q[a:b][~loose] ** 2), np.linalg.norm(q[a:b][loose])
                if room > 0 and size > 1e-12:
                    q[a:b][loose] *= np.sqrt(room) / size
        return q

    def locally_fixed(self, q: np.ndarray, fixed: np.ndarray) -> np.ndarray:
        """Per body: True where no direction the rows and the fixed values leave free turns it (no continuum)."""
        A = self.at(q)[1][:, ~fixed]
        N, free = A.T @ A, np.zeros(len(self.bodies), bool)
        # Eigenvalues first (a third of eigh's time): all above 1e-12 of the largest (singular values 1e-6), no free
        # direction at all, the usual case; else the null space's eigenvectors.
        if N.size and np.linalg.eigvalsh(N)[0] < 1e-12 * max(np.abs(N).max(), 1e-300):
            lam, V = np.linalg.eigh(N)
            Z = np.zeros((len(q), int((lam < 1e-12 * max(lam[-1], 1e-300)).sum())))
            Z[~fixed] = V[:, : Z.shape[1]]
            free = np.array([np.abs(Z[a:b]).max(initial=0.0) >= 1e-6 for _, a, b, _ in self.bodies])
        return ~free


def _end(problem, which: str, values: dict, t: float) -> str | None:
    eqs, names = problem.eqs, problem.eqs.model.coordinate_names
    fixed = np.array([n in values for n in names], bool)
    if not fixed.any():
        return None                 # nothing fixed: every pose is the optimizer's to choose
    rows = _Rows(eqs, t, np.array([values.get(n, 0.0) for n in eqs.model.inputs], float))
    target = np.array([values[n] for n in names if n in values], float)
    # A consistent configuration of the model: a generic pose near the identity (no parameter at exactly 0, which
    # has no sign to flip; a far one, e.g. upside down, stalled on its way to the fixed values) solved onto the rows
    # with every coordinate free; kept per model, time and inputs.
    cache, key = rows.starts, (t, rows.w.tobytes())
    if key not in cache:
        generic = 0.3 * np.sin(12.9898 * np.arange(1, eqs.nq + 1))
        generic[[a for _, a, _, quaternion in rows.bodies if quaternion]] = 1.0
        cache[key] = rows.solve(rows.insert(generic, np.zeros(eqs.nq, bool), []), np.ones(eqs.nq, bool))[0]
    bases = [cache[key]]
    guessed = [i for i, n in enumerate(names) if n in problem.guess]
    if guessed:
        q = bases[0].copy()
        try:                        # first: the pose meant, which the others are compared with
            q[guessed] = [float(np.ravel(problem.guess[names[i]](np.array([t])))[0]) for i in guessed]
            bases.insert(0, q)
        except Exception:           # noqa: BLE001  a broken guess is check_problem's to name; here it is no start
            pass
    solutions: list[tuple[np.ndarray, np.ndarray]] = []        # (q, every body's rotation matrix)

    def keep(q: np.ndarray, size: float, R: np.ndarray) -> bool:
        """Whether ``q`` converged to rotations not found yet (then kept); q and -q are one rotation."""
        if size >= CONVERGED or any(np.abs(R - S).max() < SAME_ROTATION for _, S in solutions):
            return False
        solutions.append((q, R))
        return True

    for base in bases:
        q, size, R = rows.onto(base, fixed, target, far=not solutions)     # not the second way after a converged one
        if not keep(q, size, R):
            continue                # no pose near this start, or one found already (whose mirrors were tried)
        for body, (_, a, b, quaternion) in enumerate(rows.bodies):
            loose = np.arange(a, b)[~fixed[a:b]]
            # Not for a body seen in two rotations already (the second start's mirrors would repeat the first's).
            seen = any(np.abs(S[body] - solutions[0][1][body]).max() >= SAME_ROTATION for _, S in solutions)
            if quaternion and loose.size and np.abs(q[loose]).max() > 1e-9 and not seen:
                flipped = q.copy()
                flipped[loose] *= -1.0      # one body's mirror: (c, 0, 0, s) -> (c, 0, 0, -s) for qw fixed
                if loose.size == b - a:
                    flipped[a] *= -1.0      # all four negated is the same rotation: the conjugate (the inverse) instead
                keep(*rows.solve(flipped, ~fixed))
    determined = functools.cache(lambda k: rows.locally_fixed(solutions[k][0], fixed))     # on first need
    found: dict[int, tuple[int, int]] = {}      # body -> the first two solutions that turn it differently
    for i, j in itertools.combinations(range(len(solutions)), 2):
        for body in np.flatnonzero(np.abs(solutions[i][1] - solutions[j][1]).max(axis=1) > SAME_ROTATION):
            if body not in found and determined(i)[body] and determined(j)[body]:
                found[body] = (i, j)
    lines = []
    for body, (i, j) in sorted(found.items()):
        name, a, b, quaternion = rows.bodies[body]
        qa, qb = solutions[i][0][a:b], solutions[j][0][a:b].copy()
        if quaternion and not fixed[a:b].any() and qa @ qb < 0:
            qb = -qb                # q and -q are one rotation: compare the parameters on one sheet
        own = [names[a + k] for k in range(b - a) if fixed[a + k]]
        flips = [qa[k] * qb[k] < 0 and min(abs(qa[k]), abs(qb[k])) > 1e-9 for k in range(b - a)]
        # The parameter to name: an unfixed one whose sign differs (its sign chooses the pose), else the most different.
        k = max((k for k in range(b - a) if not fixed[a + k]), key=lambda k: (flips[k], abs(qa[k] - qb[k])))
        p = names[a + k]
        lines.append(f"Body '{name}' ({', '.join(own or [n for n in names if n in values])} fixed"
                     f"{'' if own else ' at this end'}): {p} = {qa[k]:+.3g} or {qb[k]:+.3g}; fix {p} too (its "
                     f"{'sign' if flips[k] else 'value'} chooses the pose), e.g. "
                     f"problem.{which}({{'{p}': {qa[k]:.6g}}}) for the first.")
    return None if not lines else (
        f"The {which} values leave {'a pose' if len(lines) == 1 else 'poses'} two-fold: configurations on the "
        f"constraints (unit quaternions included) meet them with different rotations, and IPOPT lands in either "
        f"depending on its start, without a word. " + " ".join(lines))
