"""Which solution judges which mesh in hp mesh refinement (issue 19): the companion of a mesh (its degrees
raised by two), the pilot of the first mesh (every interval halved at :data:`MAX_DEGREE`), whether one mesh
covers another or is finer everywhere (then its solution may judge the other's: :func:`finer`), and the
uniform step taken where a comparison does not resolve the solution. Used by :mod:`.mesh_refinement`."""
from __future__ import annotations

import numpy as np

from .schemes import Radau

MAX_DEGREE = 7          # the companion then reaches Radau's highest degree, 9
COMPANION_EXTRA = 2


def _degrees(scheme: Radau) -> np.ndarray:
    return scheme.points_per_interval - 1


def companion_of(scheme: Radau) -> Radau:
    """The same mesh with every degree raised by :data:`COMPANION_EXTRA` (at most 9)."""
    return Radau(mesh=tuple(scheme.mesh_fractions),
                 degrees=tuple(int(min(d + COMPANION_EXTRA, 9)) for d in _degrees(scheme)))


def pilot_of(scheme: Radau) -> Radau:
    """The first mesh's companion: every interval halved, at :data:`MAX_DEGREE`, the finest mesh one
    refinement of it can ask for without splitting further. Where the next mesh asks for no more
    (:func:`covered`), the pilot's solution *is* the next solution, and a refinement needs three
    solves, not four (the solves' fixed costs, transcription and IPOPT setup, are most of a solve
    at these sizes: swing-up in joint coordinates, 54-62% of the refinement's CPU in transcriptions)."""
    mesh = scheme.mesh_fractions
    halves = np.sort(np.concatenate([mesh, (mesh[:-1] + mesh[1:]) / 2]))
    return Radau(mesh=tuple(float(m) for m in halves), degrees=(MAX_DEGREE,) * (2 * scheme.intervals))


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
    smooth (a switch), neither kind of companion is an upper bound (:func:`~.mesh_refinement._flag_nonsmooth`)."""
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
