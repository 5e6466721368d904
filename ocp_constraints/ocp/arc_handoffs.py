"""Arcs that hand a bound on to one another at one junction (issue 19; the arcs: :mod:`.imposed_arcs`).

Where a mixed constraint reaches its bound while an input rides its own, the input leaves its bound at that very
instant: the least-time crane's drive force sits at its limit until the rope's tension reaches its own, and from then
on the force is what holds the tension there (``T(x, F) = T_max``; both continuous, so the force leaves its bound
continuously, and both arcs share one junction time). Imposed as two junctions of their own, a free interval between
them that does not exist, the two arcs overlapped by a sliver on which the force and the tension were both fixed: the
imposed NLP had more equality constraints than variables (CasADi: "NLP is overconstrained") and its steps failed, so the
crane's arcs were never imposed and 1e-5 was not met. Here such a pair is one junction: the same time for the end of
one arc and the start of the next (:func:`handed_off`), moved as one root (:func:`tied`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np


def handed_off(arcs: list, runs: list[tuple[int, int]]) -> list:
    """``arcs`` (each found on the run of points ``runs[k]`` = (first, last) where its quantity is active) with every
    hand-off joined: an input's or path constraint's arc ending where another quantity's begins, with no free point
    between them (the runs overlap or touch), both given the mean of their two located times."""
    arcs = list(arcs)
    for a, (_, last) in enumerate(runs):
        for b, (first, _) in enumerate(runs):
            A, B = arcs[a], arcs[b]
            if (a == b or A.quantity == B.quantity or A.state or B.state or A.open_end or B.open_start or not 0.0 < A.end < 1.0
                    or not 0.0 < B.start < 1.0 or not runs[a][0] < first <= last + 1 <= runs[b][1] + 1):
                continue
            at = 0.5 * (A.end + B.start)
            arcs[a], arcs[b] = replace(A, end=at), replace(B, start=at)
    return arcs


def tied(junctions: list[tuple[int, str, float]]) -> np.ndarray:
    """Per junction (:func:`.imposed_arcs.inner_junctions`' order), the index of the junction whose mismatch places it:
    its own, or at a hand-off (an arc's end and another's start at one time) the starting arc's (its quantity before
    the junction, a point's own value rather than a polynomial extrapolated to it). Both mismatches vanish at the one
    root; driving the two times apart by their own secants would split the junction again."""
    lead = np.arange(len(junctions))
    for i, (k, side, at) in enumerate(junctions):
        if side != "end":
            continue
        for j, (m, other, at2) in enumerate(junctions):
            if other == "start" and m != k and abs(at2 - at) <= 1e-12:
                lead[i] = j
    return lead
