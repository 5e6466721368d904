"""The hp rule of mesh refinement (:mod:`.mesh_refinement`, step 4): the next mesh from each interval's estimate."""
from __future__ import annotations

import math

import numpy as np

from .mesh_companions import MAX_DEGREE, _degrees, _ends, reused_degree, split_pieces
from .nonsmooth import MIN_INTERVAL
from .schemes import Radau

MIN_DEGREE = 3
ROUGH_MIN = 1e-3    # fraction of the horizon below which a rough interval is not halved


def refine(scheme: Radau, ratio: np.ndarray, parents: dict | None = None,
           nonsmooth: np.ndarray | None = None, switches: dict | None = None,
           built: set | frozenset = frozenset()) -> tuple[Radau, dict]:
    """The next mesh, and each new interval's parent ``(ends) -> ratio``.

    ``ratio[k]`` is interval ``k``'s estimate over the tolerance (the largest of the gated
    quantities); ``parents`` maps an interval's ends to the ratio of the interval it was made from
    one refinement back. An interval refined last time whose ratio fell less than tenfold, and
    whose inputs or multipliers are not smooth (``nonsmooth[k]``, from
    :func:`.legendre_decay.legendre_decay`; None: not checked) is *rough* (a switch or a kink inside:
    neither a higher degree nor a split at a high degree helps much): it is split in two at :data:`MIN_DEGREE`. A smooth one gets the degree that
    the error's fall of about 4x per degree predicts, ``d + ceil(log(ratio) / log 4)``, if that is at
    most :data:`MAX_DEGREE`; else it is split at :data:`MAX_DEGREE` into the number of pieces that
    the rest of the ratio needs (error ~ h^MAX_DEGREE), 2 to :data:`.mesh_companions.MAX_PIECES`.

    ``switches[k]``: fractions of the horizon where a bound or path constraint switches inside interval
    ``k`` (:func:`.switch_detection.split_points`). Such an interval is split *at* them, at :data:`MIN_DEGREE`,
    whatever its ratio: each piece is then a smooth arc whose companion estimate holds, where halving
    would narrow the switch down only by two per refinement (minimum-time swing-up at 1e-3: 10
    halvings, the switch still inside an interval, true error 1.7x the estimate).

    ``built``: degrees whose element kinds this refinement has built already (:func:`reused_degree`): a
    raised degree is rounded up to the nearest of them.
    """
    mesh, degrees = scheme.mesh_fractions, _degrees(scheme)
    new_mesh, new_degrees, born = [0.0], [], {}
    for k, (a, b) in enumerate(zip(mesh[:-1], mesh[1:])):
        d, r = int(degrees[k]), float(ratio[k])
        if k in (switches or {}):
            pieces = [*switches[k], b]
            for lo, hi in zip([a, *pieces[:-1]], pieces):
                born[_ends(lo, hi)] = max(r, 1.0)
            new_mesh.extend(pieces)
            # At MIN_DEGREE: beside a jump the NLP holds the bounds loosely and a higher degree only oscillates more
            # (the minimum-time swing-up from the degree-5 first mesh, its pieces at degree 5: 1e-3 not met after
            # 10 refinements, multipliers' estimate 1.6e-2; at degree 3, met on 75 points).
            new_degrees.extend([min(d, MIN_DEGREE)] * len(pieces))
            continue
        if r <= 1.0:
            new_mesh.append(b)
            new_degrees.append(d)
            continue
        needed = d + max(1, math.ceil(math.log(r) / math.log(4.0)))
        parent = (parents or {}).get(_ends(a, b))
        # Not below ROUGH_MIN: a switch no bound locates is narrowed that far by halving; shorter, the
        # NLP's inputs and multipliers next to a switch grow noisier, not smoother (see .switch_detection.touched).
        rough = (parent is not None and r > parent / 10.0 and (nonsmooth is None or bool(nonsmooth[k]))
                 and b - a > ROUGH_MIN)
        if b - a <= MIN_INTERVAL:
            pieces, degree = [b], min(d + 1, MAX_DEGREE)
        elif rough:
            pieces, degree = [(a + b) / 2, b], MIN_DEGREE
        elif needed <= MAX_DEGREE:
            pieces, degree = [b], reused_degree(needed, built)
        else:
            # At MAX_DEGREE the ratio left is r / 4^(MAX_DEGREE - d); n pieces divide it by about
            # n^MAX_DEGREE (the multipliers' order; the states' is one more): as many pieces as that
            # predicts, so that a steep tolerance is met in one more refinement, not several halvings
            # (swing-up at 1e-8: 3 refinements with halving, 2 with this).
            n = split_pieces(r, d)
            pieces, degree = [a + (b - a) * j / n for j in range(1, n)] + [b], MAX_DEGREE
        for lo, hi in zip([a, *pieces[:-1]], pieces):
            born[_ends(lo, hi)] = r
        new_mesh.extend(pieces)
        new_degrees.extend([degree] * len(pieces))
    new_mesh[-1] = 1.0
    return Radau(mesh=tuple(float(m) for m in new_mesh), degrees=tuple(new_degrees)), born
