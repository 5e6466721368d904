"""Which solution judges which mesh in hp mesh refinement (issue 19): the companion of a mesh (its degrees
raised by two), the pilot of the first mesh (every interval halved at :data:`MAX_DEGREE`), whether one mesh
covers another or is finer everywhere (then its solution may judge the other's: :func:`finer`), and the
uniform step taken where a comparison does not resolve the solution. Used by :mod:`.mesh_refinement`."""
from __future__ import annotations

import math

import numpy as np

from .legendre_decay import predicted_error
from .schemes import Radau

MAX_DEGREE = 7          # the companion then reaches Radau's highest degree, 9
COMPANION_EXTRA = 2
MAX_PIECES = 8          # an interval is split into at most this many in one refinement


def _degrees(scheme: Radau) -> np.ndarray:
    return scheme.points_per_interval - 1


def companion_of(scheme: Radau, halved=()) -> Radau:
    """The same mesh with every degree raised by :data:`COMPANION_EXTRA` (at most 9); the intervals ``halved``
    (indices) also halved: those holding a junction located inside them (an input leaving its bound, a path
    constraint becoming active; :func:`.switch_detection.detect_switches`). There the inputs and multipliers kink,
    their error falls like h, not with the degree, and a companion two degrees up on the same interval carries
    nearly the same error: a newcomer's push leaving its bound inside an interval was "met" at 1e-4 with its load's
    true error 1.42x the estimate; on halves it is 0.30 of it (tests/test_refinement_junctions.py)."""
    mesh, out, degrees = scheme.mesh_fractions, [0.0], []
    for k, (a, b, d) in enumerate(zip(mesh[:-1], mesh[1:], _degrees(scheme))):
        d = int(min(d + COMPANION_EXTRA, 9))
        if k in halved:
            out.append((a + b) / 2)
            degrees.append(d)
        out.append(b)
        degrees.append(d)
    out[-1] = 1.0
    return Radau(mesh=tuple(float(m) for m in out), degrees=tuple(degrees))


def pilot_of(scheme: Radau, pieces=None) -> Radau:
    """The first mesh's companion: every interval halved, at :data:`MAX_DEGREE`, the finest mesh one
    refinement of it can ask for without splitting further. Where the next mesh asks for no more
    (:func:`covered`), the pilot's solution *is* the next solution, and a refinement needs three
    solves, not four (the solves' fixed costs, transcription and IPOPT setup, are most of a solve
    at these sizes: swing-up in joint coordinates, 54-62% of the refinement's CPU in transcriptions).

    ``pieces[k]`` (default 2): interval ``k`` cut into that many equal pieces (:func:`pilot_pieces`:
    where the first solution's own Legendre coefficients predict that halving at :data:`MAX_DEGREE` will not
    meet the tolerance, the pilot is cut as the next mesh would be, so that it can be the next mesh)."""
    mesh = scheme.mesh_fractions
    n = np.full(scheme.intervals, 2) if pieces is None else np.maximum(2, np.asarray(pieces, int))
    points = [mesh[0]]
    for a, b, m in zip(mesh[:-1], mesh[1:], n):
        points += ([(a + b) / 2] if m == 2 else [a + (b - a) * j / m for j in range(1, m)]) + [b]
    points[-1] = 1.0
    return Radau(mesh=tuple(float(m) for m in points), degrees=(MAX_DEGREE,) * int(n.sum()))


def as_fine(scheme: Radau, by: Radau) -> bool:
    """Whether every interval of ``by`` is no longer than, and of no lower degree than, each interval of
    ``scheme`` it overlaps: ``by`` asks for at least what ``scheme`` does everywhere, its mesh points
    not necessarily among ``scheme``'s (``by`` cut in 4 where ``scheme`` is cut in 3)."""
    mesh, theirs = scheme.mesh_fractions, by.mesh_fractions
    tiny = 1e-12
    for lo, hi, d in zip(theirs[:-1], theirs[1:], _degrees(by)):
        k0 = max(int(np.searchsorted(mesh, lo + tiny, side="right")) - 1, 0)
        k1 = min(int(np.searchsorted(mesh, hi - tiny, side="left")), scheme.intervals)
        ks = np.arange(k0, max(k1, k0 + 1))
        if np.any(hi - lo > np.diff(mesh)[ks] * (1 + 1e-9)) or np.any(d < _degrees(scheme)[ks]):
            return False
    return True


def covered(scheme: Radau, by: Radau) -> bool:
    """Whether ``by`` is at least as fine as ``scheme`` everywhere: its mesh holds every mesh point of
    ``scheme`` and each of its intervals has at least the degree of the interval of ``scheme`` it lies in."""
    ours = {_ends(m, m)[0] for m in by.mesh_fractions}
    if not all(_ends(m, m)[0] in ours for m in scheme.mesh_fractions):
        return False
    mid = (by.mesh_fractions[:-1] + by.mesh_fractions[1:]) / 2
    k = np.clip(np.searchsorted(scheme.mesh_fractions, mid, side="right") - 1, 0, scheme.intervals - 1)
    return bool(np.all(_degrees(by) >= _degrees(scheme)[k]))


def finer(scheme: Radau, by: Radau) -> bool:
    """Whether a solution on ``by`` may serve as the companion of a solution on ``scheme``: ``by``'s mesh
    holds every mesh point of ``scheme``, and each interval of ``scheme`` (length ``h``, degree ``d``) is
    either cut by ``by`` into pieces of at most ``h / 2`` at degrees ``>= d``, or kept whole at degree
    ``>= d + COMPANION_EXTRA`` (the companion of :func:`companion_of`).

    Why the estimate stays an upper bound: with ``e`` the solution's error and ``e_c`` the companion's,
    ``SAFETY |s - c|`` lies in ``[SAFETY (e - e_c), SAFETY (e + e_c)]``, at least ``e`` while ``e_c <= e / 2``
    (:data:`~.error_estimate.SAFETY` = 2). Halving an interval at the same degree divides the error by
    ``2^p``, ``p`` the order: at least ``d`` (the multipliers, algebraic variables of an index-2 problem;
    states ``d + 1`` between the points), so at least 8 at :data:`~.mesh_refinement.MIN_DEGREE` (3); raising the degree by two
    on the same interval divides it by ~16 where the solution is smooth (the ~4x per degree of
    :func:`~.mesh_refinement.refine`). Then ``e_c <= e / 8`` and true / estimate lies in ``[1 / (2 (1 + 1/8)), 1 / (2 (1 - 1/8))]``
    = ``[0.44, 0.57]``; the bench checks it against the Pontryagin reference. Where the solution is not
    smooth (a switch), neither kind of companion is an upper bound (:func:`~.nonsmooth.flag_nonsmooth`)."""
    if not covered(scheme, by):
        return False
    mesh, theirs = scheme.mesh_fractions, by.mesh_fractions
    mid = (theirs[:-1] + theirs[1:]) / 2
    k = np.clip(np.searchsorted(mesh, mid, side="right") - 1, 0, scheme.intervals - 1)
    halved = np.diff(theirs) <= np.diff(mesh)[k] / 2 * (1 + 1e-9)
    raised = _degrees(by) >= _degrees(scheme)[k] + COMPANION_EXTRA
    return bool(np.all(halved | raised))


def uniform_step(companion: Radau) -> Radau:
    """The next mesh where the solution is not yet resolved (:func:`.error_estimate.resolution`): the
    companion's mesh (the finer of the two just solved), every interval halved, at its degrees up to
    :data:`MAX_DEGREE`. Uniform, because an unresolved comparison does not say where the error is."""
    mesh = companion.mesh_fractions
    halves = np.sort(np.concatenate([mesh, (mesh[:-1] + mesh[1:]) / 2]))
    degrees = np.repeat(np.minimum(_degrees(companion), MAX_DEGREE), 2)
    return Radau(mesh=tuple(float(m) for m in halves), degrees=tuple(int(d) for d in degrees))


def _ends(a: float, b: float) -> tuple[float, float]:
    return round(float(a), 13), round(float(b), 13)


def finer_at_hand(scheme: Radau, at_hand: list):
    """The finest solution at hand that may judge a solution on ``scheme`` (:func:`finer`), or None."""
    fit = [s for s in at_hand if finer(scheme, s.transcription.scheme)]
    return max(fit, key=lambda s: s.transcription.scheme.point_count) if fit else None


def split_pieces(ratio: float, degree: int) -> int:
    """Pieces at :data:`MAX_DEGREE` that an interval of ``degree`` whose error is ``ratio`` times the
    tolerance needs (:func:`.mesh_refinement.refine`): the ratio left at :data:`MAX_DEGREE`, ``ratio / 4^(MAX_DEGREE - degree)``,
    divided by about ``n^MAX_DEGREE``; 2 to :data:`MAX_PIECES`."""
    left = ratio / 4.0 ** (MAX_DEGREE - degree)
    return int(min(MAX_PIECES, max(2, math.ceil(left ** (1.0 / MAX_DEGREE)))))


def pilot_pieces(sol, tol: float) -> np.ndarray:
    """How finely the pilot cuts each interval of the first mesh: in two, or, where the first solution's
    own Legendre coefficients predict an error (:func:`.legendre_decay.predicted_error`) that a
    halving at :data:`MAX_DEGREE` would not bring below ``tol`` (:func:`split_pieces` asks for more), in as
    many pieces as that asks for. Then the next mesh, from the pilot's estimate, asks for no more than the
    pilot has (:func:`.mesh_companions.as_fine`) and the pilot is the next solution: at a tight tolerance
    three solves instead of four (swing-up at 1e-8: the first mesh, a pilot of 37 intervals, its
    companion; was the first mesh, a pilot of 20, 33 intervals, their companion). A prediction too high
    costs a larger pilot; too low, the fourth solve as before. The estimate is never the prediction. Where
    the coefficients do not fall on every interval (the first mesh does not resolve the solution), every
    interval is halved as before: the next mesh then follows from the pilot's own, not from this."""
    degrees = _degrees(sol.transcription.scheme)
    predicted, falls = predicted_error(sol)
    if not falls.all():     # not resolved where they do not fall: the comparison with the pilot will say how
        return np.full(len(degrees), 2)
    return np.array([split_pieces(r, int(d)) for r, d in zip(predicted / tol, degrees)])


def reused_degree(needed: int, built) -> int:
    """``needed``, or the smallest degree above it up to :data:`MAX_DEGREE` whose element kinds are ``built``.

    Why: a degree new to the refinement costs its element kinds (the defects of an interval of that
    degree, and their symbolic Jacobian and Hessian, :mod:`.transcription_elements`, :mod:`.nlp_assembly`):
    5-17 ms of CPU each on the swing-up in joint coordinates (degrees 4-9), more on larger models; a degree
    or two more on the intervals that are raised costs a few points, and errs on the accurate side (swing-up
    at 1e-4: degrees 5-7 on 10 intervals, 63 points, two new kinds; all 7: 71 points, none)."""
    return min([d for d in built if needed <= d <= MAX_DEGREE], default=needed)


RESTART_DEGREE = 3


def low_degree(scheme: Radau, degree: int = RESTART_DEGREE) -> Radau:
    """``scheme`` at ``degree``, each interval cut into as many equal pieces as keep at least its points: the mesh a
    refinement starts again from, a multi-start, where a finer mesh did not solve (:func:`.mesh_progress.restarted`). From a
    guess far from the optimum a cold solve is surer at a low degree: a high degree's polynomials swing far between
    a poor guess's points, and IPOPT's steps with them (a seventh newcomer's URDF arm: Radau 7 x 20 from the problem's
    guess not solved in 3,000 iterations on one machine, in 20 on another; Radau 3 x 40 in 19 on both). The refinement
    raises the degrees again where the solution is smooth."""
    mesh, degrees = scheme.mesh_fractions, _degrees(scheme)
    points = [mesh[0]]
    for a, b, p in zip(mesh[:-1], mesh[1:], degrees):
        m = max(1, math.ceil(p / degree))
        points += [a + (b - a) * j / m for j in range(1, m)] + [b]
    points[-1] = 1.0
    return Radau(mesh=tuple(float(x) for x in points), degrees=(degree,) * (len(points) - 1))
