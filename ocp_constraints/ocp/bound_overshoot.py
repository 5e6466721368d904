"""How far a solution's coordinates and speeds pass their bounds *between* the collocation points.

Collocation holds a bound at the points only; between them each state is the interval's polynomial, which may
pass the bound. Along an arc on the bound the polynomial stays on it, but where a position bound is *touched* at
one instant (the bound's multiplier an impulse there, a second-order state constraint) the optimum puts the touch
between points and the polynomial goes past the bound. A fourth newcomer's cart-pole, its cart position bounded
at 0.624 m and reached once at 0.6356 s: the bound held at every point (largest 0.6240000010) and was passed by
6.0e-4, 2.4e-4 and 7.3e-5 m between them on the meshes its refinement ended on at 1e-3, 1e-4 and 1e-5, where the
refinement stalled with the true error 2-9x its estimate (``results/bench/refinement_newcomer4.md``). The
refinement does not locate such touches; it says how far its solution passes a bound, where that is more than the
tolerance (:func:`name_overshoots`).
"""
from __future__ import annotations

import numpy as np

SAMPLES = 16        # times per interval, besides its points, at which the polynomials are read


def overshoots(solution) -> list[tuple[str, float, float]]:
    """``(name, amount, t)`` for each bounded coordinate or speed of the user's problem that its polynomial passes
    between the points: the largest amount past the bound (in the quantity's units) and where (s), worst first."""
    tr = solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    states = set(pr.model.coordinate_names + pr.model.speed_names)
    named = [(name, lo, hi) for name, (lo, hi) in pr.bounds.items() if name in states]
    if not named:
        return []
    mesh = tr.scheme.mesh_fractions
    inner = (np.arange(1, SAMPLES + 1) / (SAMPLES + 1))[None, :]
    t = ((mesh[:-1, None] + np.diff(mesh)[:, None] * inner).ravel()) * solution.t_final
    found = []
    for name, lo, hi in named:
        v = solution.polynomial(name, t)
        past = np.maximum(lo - v, v - hi)
        k = int(np.argmax(past))
        if past[k] > 0.0:
            found.append((name, float(past[k]), float(t[k])))
    return sorted(found, key=lambda f: -f[1])


def name_overshoots(solution, record: dict, tol: float):
    """Record ``"bounds_passed_between_points"`` (:func:`overshoots`, those over ``tol``) in the refinement's ``record``
    and say so in its message; ``solution`` returned as it is."""
    passed = [f for f in overshoots(solution) if f[1] > tol]
    if passed:
        record["bounds_passed_between_points"] = [{"quantity": n, "amount": a, "t": t} for n, a, t in passed]
        where = ", ".join(f"'{n}' by {a:.1e} at {t:.4g} s" for n, a, t in passed[:3])
        record["message"] = (record.get("message", "") + f"; between its collocation points the solution passes the "
                             f"bound on {where} (a bound is held at the points only; where it is touched at an instant "
                             f"the refinement does not locate the touch)")
    return solution
