"""What a companion's difference misses at kinks and junctions, and the floors the estimate gets there (issue 19).

:func:`.error_estimate.estimate_error` takes twice the difference of a solution and its companion (the same mesh, higher
degrees). At a kink inside an interval (an input or a load leaving its bound) the difference falls short of the error
(:func:`kink_floor`); at an imposed junction (:mod:`.imposed_arcs`) the two differ only between their junction times,
where the mesh has no sample (:func:`with_junction_samples`).
"""
from __future__ import annotations

import numpy as np


def with_junction_samples(grid: tuple[np.ndarray, np.ndarray], solution, companion) -> tuple[np.ndarray, np.ndarray]:
    """The sample grid with the companion's imposed junctions (:mod:`.imposed_arcs`, each at its own root) added: where
    the solution's junction is off by ``d``, its loads differ from the companion's by their slope change times ``d``
    only between the two junctions, which no sample of the solution's mesh falls in (an eighth newcomer's pendulum on
    a stop at 1e-6: its entry 1.05e-7 s late, the companion's 3e-10 s off, the hinge force's true error 1.08x the
    estimate before this, ``scripts/refinement_newcomer8``)."""
    fractions, owner = grid
    arcs = getattr(companion.transcription, "arcs", ())
    extra = np.array([x for a in arcs for x in (a.start, a.end) if 0.0 < x < 1.0])
    if not extra.size:
        return fractions, owner
    mesh = solution.transcription.scheme.mesh_fractions
    at = np.clip(np.searchsorted(mesh, extra, side="right") - 1, 0, len(mesh) - 2)
    fractions, owner = np.concatenate([fractions, extra]), np.concatenate([owner, at])
    order = np.lexsort((fractions, owner))          # by interval, then time (made_here reads each interval's run)
    return fractions[order], owner[order]


# A degree-p polynomial misses a kink |x| on [-1, 1] by about 0.28 / p at best (Bernstein); a kink of slope change
# s on an interval of length h, at its middle, by about 0.07 s h / p. Collocation is no best approximation: 0.25.
KINK_C = 0.25


def floored_kinks(switches) -> list:
    """The located switches whose interval's estimate :func:`kink_floor` floors: junctions of an input or a path
    constraint inside an interval (a state's bound is reached tangentially: no floor; where its inputs and multipliers
    kink all the same, a fifth newcomer's arm angle bound, the companion that halves the junction's interval sees it
    once the junction is located in the right interval, :func:`.switch_location._approach`; a floor there too put
    Bryson-Denham's push estimate at 3.1e-3 for a true 1.5e-7, its junction 6.7e-7 of the horizon from a mesh point)."""
    return [w for w in switches if w.kind == "junction" and w.inside and w.source != "state"]


def kink_floor(solution, est, switches, sample_names: dict) -> None:
    """Where an input leaves or reaches its bound inside an interval, or a path constraint its bound (a junction,
    located by :mod:`.switch_detection`), the inputs and the multipliers kink: their estimate on that interval is at
    least ``KINK_C |slope change| h / p`` (relative to their scales, ``h`` the interval's length in s, ``p`` its
    degree), the slope change read from the solution's two points on each side. Why: at a kink the error of a
    polynomial falls only like 1 / p, so the companion two degrees up is closer to the truth by about 2 / (p + 2)
    of the error, and their difference under-estimates it (the pushes clipped at an input bound,
    scripts/refinement_holdouts.py: multipliers' true error 1.27x and 1.52x the estimate). A floor from the
    kink's own size, not a factor on the difference: a factor (p + 2) / 2 also multiplied IPOPT's noise on the
    short intervals beside a junction, where an input is held off its bound by mu / z (the push at 1e-4 was
    not met; ``results/bench/refinement_junction_experiments.md``); this floor falls with the interval. A path
    constraint's kink the same (the rod's hinge-force limit of the holdouts from Radau 5 N = 10 at 1e-3: the
    multipliers' true error was 2.0x the estimate before its junction was located inside its interval,
    :func:`.switch_location._junction`, and floored). A state bound's junction floors the multipliers only (its
    interval's smoothness is judged as before, :func:`floored_kinks`): inside an interval as above, and where it was
    put at a mesh point by the half gap to the interval's first collocation point, where it may lie (an eighth
    newcomer's pendulum riding a stop, at 1e-3: the hinge force's true error 1.25x the estimate at the stop's exit,
    1.8e-4 s past the mesh point it was put at; scripts/refinement_newcomer8/, results/bench/refinement_newcomer8.md),
    unless its arc is imposed (:mod:`.imposed_arcs`: the junction is that mesh point, placed by its input's continuity)."""
    kinks = floored_kinks(switches) + [w for w in switches if w.kind == "junction" and w.source == "state" and not w.imposed]
    if not kinks:
        return
    tr = solution.transcription
    mesh, t, T = tr.scheme.mesh_fractions, solution.t, solution.t_final
    # Each quantity's values at the points, relative to its scale: read once for all the kinks.
    values = {q: np.array([np.asarray(solution.sample(n), float) for n in sample_names[q]]) / scale
              for q, scale in (("multipliers", est.load_scale), ("inputs", est.input_scale)) if sample_names[q] and scale}
    for w in kinks:
        before, after = np.flatnonzero(t < w.fraction * T)[-2:], np.flatnonzero(t > w.fraction * T)[:2]
        if len(before) < 2 or len(after) < 2:
            continue
        k = w.interval
        reach = KINK_C * (mesh[k + 1] - mesh[k]) * T / len(tr.local[k].tau)
        if w.source == "state" and not w.inside:
            # A state bound's junction put at a mesh point (switch_detection: before the middle of the gap to the
            # interval's first collocation point) may lie anywhere in that half gap: the interval's polynomial
            # through its points, all past the kink, misses the mesh point's value by up to the slope change times it.
            reach = 0.5 * (tr.fractions[tr.offsets[k] + 1] - mesh[k]) * T
        for q, V in values.items():
            if w.source == "state" and q != "multipliers":
                continue        # the inputs' estimate is reported, not gated: left as the difference gives it
            slope = [(V[:, b] - V[:, a]) / (t[b] - t[a]) for a, b in (before, after)]
            model = reach * float(np.abs(slope[1] - slope[0]).max())
            est.per_interval[q][k] = max(est.per_interval[q][k], model)
            if q in est.local:      # the kink is made here
                est.local[q][k] = max(est.local[q][k], model)
            est.totals[q] = max(est.totals[q], model)
