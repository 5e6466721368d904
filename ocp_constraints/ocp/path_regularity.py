"""Whether a path constraint moves with the inputs along its arc, and where (issue 19; the arcs: :mod:`.imposed_arcs`).

A mixed constraint (a load bound: the rope's tension of a crane, a hinge force) held as an equality over an arc
fixes the inputs there only where its derivative in them does not vanish (its regularity). Where it does vanish
mid-arc (the crane's rope hangs plumb at the middle of its second tension arc, and the trolley's force cannot change
the tension to first order), the arc is imposed only on its *regular pieces*, from each junction to where the
derivative has fallen to :data:`PIECE` of its value there (:func:`regular_pieces`); the rest of the arc keeps its
bound as an inequality, which holds it there with a multiplier well away from zero (the barrier's rounding, ``mu /
z``, matters only where ``z`` falls to zero: at the junctions, which the pieces impose).
"""
from __future__ import annotations

import numpy as np

REGULAR = 1e-3      # a path row's scaled derivative in the inputs below this: it does not move with them there
PIECE = 0.5         # a regular piece ends where the derivative has fallen below this fraction of the junction's


def input_gradients(solution, label: str, at: np.ndarray) -> np.ndarray:
    """Path constraint ``label``'s row's derivative in each input, times the input's scale (its bounds' largest
    magnitude, else 1), at points ``at``: one row per point (the row is in the NLP's scaling, about 1 at the bound)."""
    tr = solution.transcription
    path = tr.point_pieces[0]["path"]
    j = [c.label for c in tr.nlp_path_constraints].index(label)
    X, _, L, W, _, _ = (np.asarray(b, float) for b in tr.layout.split(np.asarray(solution.decision_vector, float)))
    pr = getattr(tr, "user_problem", tr.problem)
    span = np.array([max([abs(b) for b in pr.bounds.get(n, (np.nan, np.nan)) if np.isfinite(b)] + [1.0])
                     for n in pr.model.inputs])
    out = np.zeros((len(at), W.shape[0]))
    for r, i in enumerate(at):
        base = float(np.asarray(path(X[:, i], L[:, i], W[:, i], solution.t[i]))[j, 0])
        for k in range(W.shape[0]):
            w = W[:, i].copy()
            w[k] += 1e-6 * span[k]
            out[r, k] = (float(np.asarray(path(X[:, i], L[:, i], w, solution.t[i]))[j, 0]) - base) / 1e-6
    return out


def regular_over(solution, label: str, points: np.ndarray) -> bool:
    """Whether path constraint ``label`` moves with the inputs all along an arc's ``points``: its scaled gradient in
    them (:func:`input_gradients`) over :data:`REGULAR` at every point and never reversing between neighbours (through
    zero). That is the regularity of a mixed constraint on its arc, under which the inputs there follow from it
    (Hartl, Sethi and Vickson 1995, sec. 3); leaving its bound it then turns with them, transversally, and its mismatch
    at a junction has a simple root. Where it fails:

    - a load that follows the speeds alone (a hinge's centripetal pull, a speed limit seen through a multiplier)
      leaves its bound tangentially: its mismatch is flat at the root and the secant wanders (the holdouts' hinge at
      1e-4: twelve steps, none converged, 15% more CPU); in maximal coordinates a multiplier is a variable of its own
      and no row moves with the inputs: there only the inputs' arcs are imposed;
    - held as an equality where the gradient vanishes, the imposed NLP is singular: the least-time crane's rope
      tension, whose derivative in the drive force goes through zero mid-arc where the rope hangs plumb, took MUMPS
      166 s of CPU to fail one step (12 s for the whole refinement without it)."""
    return _regular(input_gradients(solution, label, points))


def _regular(g: np.ndarray) -> bool:
    """Gradients ``g`` (one row per point) above :data:`REGULAR` everywhere and never reversing between neighbours."""
    return bool(np.all(np.abs(g).max(axis=1) > REGULAR) and np.all(np.sum(g[1:] * g[:-1], axis=1) > 0.0))


def regular_pieces(solution, label: str, points: np.ndarray, inner_start: bool, inner_end: bool) -> list[tuple[int, int]]:
    """The runs of ``points`` (an arc's, in order) over which path constraint ``label`` is imposed, as ``(first, last)``
    indices into ``points``: the whole arc where it is regular all along (:func:`regular_over`); otherwise a piece from
    each inner junction (``inner_start``, ``inner_end``) over which its scaled gradient keeps its direction and at
    least :data:`PIECE` of its size at the junction, where that is two points or more (module notes)."""
    g = input_gradients(solution, label, points)
    if _regular(g):
        return [(0, len(points) - 1)]
    size = np.abs(g).max(axis=1)

    def reach(order):
        k0 = order[0]
        if size[k0] <= REGULAR:
            return None
        kept = [k for k in order if size[k] >= PIECE * size[k0] and g[k] @ g[k0] > 0.0]
        n = next((i for i, k in enumerate(order) if k not in kept), len(order))   # the first run only
        return order[:n] if n >= 2 else None

    pieces = []
    lead = reach(list(range(len(points)))) if inner_start else None
    trail = reach(list(range(len(points) - 1, -1, -1))) if inner_end else None
    if lead:
        pieces.append((lead[0], lead[-1]))
    if trail and (not lead or min(trail) > lead[-1] + 1):
        pieces.append((min(trail), trail[0]))
    return pieces
