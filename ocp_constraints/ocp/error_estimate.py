"""A-posteriori error of a collocation solution, per mesh interval and per quantity.

The estimate compares the solution with a *companion*: the same problem solved on the same
mesh with every interval's Radau degree raised by two (warm-started from the solution, so a
few IPOPT iterations). Where the solution is smooth, the companion's error is smaller by a
large factor (Radau of degree ``d`` is of order ``2d - 1`` at the mesh points and about ``d``
for the multipliers, which are algebraic variables of an index-2 problem), so their
difference is the solution's error; :data:`SAFETY` multiplies it to cover the companion's
own share. Both are compared through their collocation polynomials on a grid of
:data:`SAMPLES_PER_POINT` times per collocation point inside every interval, in normalized
time (the final time may be free).

Quantities (each its own number, the contract of issue 19):

- ``states``: coordinates and speeds, absolute (SI units: m, rad, m/s, rad/s);
- ``multipliers``: the multipliers ``lambda`` (the constraint forces and moments of eq. 26),
  relative to the largest load, ``max |lambda|`` over the companion's samples;
- ``inputs``: the controls, relative to the largest ``|input|`` (reported, not refined on);
- ``t_final``: the final time's difference (s), where it is free.

Multipliers and inputs leave out ``t = 0``: Radau has no collocation point there, its inputs
are extrapolated and ``lambda_0`` follows from the acceleration-level constraint, so its
error is that of an extrapolation, not of the scheme (the bench reports it apart too).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SAFETY = 2.0
SAMPLES_PER_POINT = 2
QUANTITIES = ("states", "multipliers", "inputs")


@dataclass
class ErrorEstimate:
    """Estimated error per quantity (largest over the horizon) and per interval.

    ``per_interval[q][k]``: the estimate of quantity ``q`` on interval ``k`` (same units and
    scaling as ``totals[q]``). ``load_scale`` (the largest ``|lambda|``, N or N m) and
    ``input_scale`` are the divisors of the relative quantities.
    """

    totals: dict[str, float]
    per_interval: dict[str, np.ndarray]
    load_scale: float
    input_scale: float
    worst: dict[str, str] = field(default_factory=dict)
    # How far apart the two solutions are as a whole (see :func:`resolution`): the objectives'
    # relative difference and the states' largest difference over their range; None until measured.
    objective_change: float | None = None
    state_change: float | None = None
    # Per interval, how much the states' difference changes across it (:func:`compare`): the error made there,
    # where ``per_interval["states"]`` also holds the error carried in from before (:meth:`refinement_ratio`).
    local_states: np.ndarray | None = None

    def as_dict(self) -> dict:
        out = {"estimate": dict(self.totals), "worst": dict(self.worst), "load_scale": self.load_scale,
               "input_scale": self.input_scale}
        if self.objective_change is not None:
            out.update(objective_change=self.objective_change, state_change=self.state_change,
                       resolved=self.resolved)
        return out

    def refinement_ratio(self, tolerance: float, gated) -> np.ndarray:
        """Per interval, the estimate over ``tolerance``, the largest over the ``gated`` quantities: where to refine.

        The states' error is carried along by the dynamics: an error made at one spot (a junction where a
        path constraint becomes active, a kink) shows in the states' difference on every later interval,
        and refining every interval where it shows doubles the whole mesh for an error made at two points
        (the cart-pole with a bounded hinge force at 1e-3: on 167 intervals the states' estimate was above
        the tolerance on three quarters of them, 3.6x at the median, while the change of the difference
        across an interval was 0.23x the tolerance at the median and 3.6x at the junctions). So while the
        states' estimate is above the tolerance, their per-interval share is where the difference *changes*
        (``local_states``), scaled so that the largest is the whole estimate: the interval that makes most of
        the error gets the ratio of the whole, the others in proportion to what they make. Met or not is
        still decided on the whole estimate (``totals``), which this leaves as it is."""
        per = dict(self.per_interval)
        total, local = self.totals.get("states", 0.0), self.local_states
        if "states" in gated and local is not None and total > tolerance and local.max() > 0.0:
            per["states"] = local * (total / local.max())
        return np.max([per[q] for q in gated], axis=0) / tolerance

    @property
    def resolved(self) -> bool:
        """Whether the companion differs from the solution by what a mesh error can be (:func:`resolution`)."""
        return (self.objective_change is None
                or (self.objective_change <= UNRESOLVED_OBJECTIVE and self.state_change <= UNRESOLVED_STATE))


def sample_grid(transcription, per_point: int = SAMPLES_PER_POINT) -> tuple[np.ndarray, np.ndarray]:
    """Normalized times in ``[0, 1]`` (``per_point`` per collocation point, evenly in every interval,
    its ends included) and the interval of each."""
    mesh = transcription.scheme.mesh_fractions
    fractions, owner = [], []
    for k in range(transcription.scheme.intervals):
        m = per_point * (len(transcription.interval_points(k)) - 1) + 1
        s = np.linspace(mesh[k], mesh[k + 1], m)
        fractions.append(s)
        owner.append(np.full(m, k))
    return np.concatenate(fractions), np.concatenate(owner)


def values_at(solution, fractions: np.ndarray) -> dict[str, np.ndarray]:
    """States (``nx x n``), multipliers and inputs of ``solution`` at normalized times ``fractions``,
    queried by name (:meth:`OCPSolution.interpolate`): the same for a solution of the maximal NLP
    and of the joint-coordinate one, whose states and multipliers are the bodies' (the joints'
    multipliers from their bodies' balances, :mod:`~ocp_constraints.mechanics.generalized`)."""
    t = np.asarray(fractions, dtype=float) * solution.t_final
    return {q: np.array([solution.interpolate(n, t) for n in labels]).reshape(len(labels), t.size)
            for q, labels in names(solution).items()}


def names(solution) -> dict[str, list[str]]:
    """The names of each quantity: the bodies' coordinates and speeds, every constraint's
    ``<constraint>.lambda`` (also those a joint-coordinate NLP has no variable for), the inputs."""
    eqs = solution.trajectory.eqs
    return {"states": eqs.model.coordinate_names + eqs.model.speed_names,
            "multipliers": [f"{c}.lambda" for c in eqs.constraint_names],
            "inputs": list(eqs.model.inputs)}


def compare(values: dict[str, np.ndarray], reference: dict[str, np.ndarray], fractions: np.ndarray,
            owner: np.ndarray, intervals: int, labels: dict[str, list[str]], windows=()) -> ErrorEstimate:
    """Differences of ``values`` from ``reference`` (both as :func:`values_at` gives them) per
    quantity and interval: states absolute, multipliers and inputs relative to the reference's
    largest magnitude, ``t = 0`` left out of those two (see the module's notes), and so are the
    ``windows`` (``(from, to)`` fractions: the brackets of jumps, :func:`.switch_detection.jump_windows`)."""
    inner = fractions > 0.0
    for lo, hi in windows:
        inner &= (fractions < lo) | (fractions > hi)
    scales = {"states": 1.0}
    for q in ("multipliers", "inputs"):
        r = reference[q][:, inner]
        scales[q] = float(np.abs(r).max()) if r.size and np.abs(r).max() > 0 else 1.0
    totals, per_interval, worst = {}, {}, {}
    for q in QUANTITIES:
        diff = np.abs(values[q] - reference[q]) / scales[q]
        if q != "states":
            diff = diff[:, inner]
        where = owner if q == "states" else owner[inner]
        pointwise = diff.max(axis=0) if diff.shape[0] else np.zeros(diff.shape[1])
        per_interval[q] = np.zeros(intervals)
        np.maximum.at(per_interval[q], where, pointwise)
        totals[q] = float(pointwise.max()) if pointwise.size else 0.0
        if diff.size:
            worst[q] = labels[q][int(diff.max(axis=1).argmax())]
    # The states' difference less its value at the start of each interval: what the interval adds to it.
    drift = values["states"] - reference["states"]
    starts = np.searchsorted(owner, np.arange(intervals))
    local = np.zeros(intervals)
    if drift.size:
        np.maximum.at(local, owner, np.abs(drift - drift[:, starts[owner]]).max(axis=0))
    return ErrorEstimate(totals, per_interval, scales["multipliers"], scales["inputs"], worst, local_states=local)


def resolution(solution, companion, values: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """How far apart ``solution`` and its ``companion`` are as a whole: the objectives' relative
    difference ``|J - J_c| / max(|J_c|, 1e-12)``, and the largest difference of a state over that
    state's range on the companion (``values``, ``reference``: the states, one row each).

    The estimate of :func:`estimate_error` assumes both are the same optimum, each close to the exact
    one, the companion much closer. Where the mesh does not resolve the solution yet, the two are
    different shapes (on coarse meshes a different local optimum, or the same one far from its limit):
    the acrobot on 10 intervals of degree 3, J = 1.80 against its companion's 40.0 (converged optimum
    21.5); on 76 intervals of degree 7, 22.6 against 23.8, the states apart by a tenth of their range.
    Their difference then measures nothing per interval, and refining where it is largest chases
    noise (the acrobot ended on 571 intervals, 4,000 points, where a uniform Radau 7 N = 160 suffices).
    Above :data:`UNRESOLVED_OBJECTIVE` or :data:`UNRESOLVED_STATE`, the refinement refines uniformly
    instead (:mod:`.mesh_refinement`)."""
    J, Jc = float(solution.objective), float(companion.objective)
    objective = abs(J - Jc) / max(abs(Jc), 1e-12)
    span = reference.max(axis=1) - reference.min(axis=1) if reference.size else np.zeros(0)
    moving = span > 1e-9
    if not moving.any():
        return objective, 0.0
    state = float((np.abs(values - reference).max(axis=1)[moving] / span[moving]).max())
    return objective, state


# A mesh error at the tolerances this refinement is for (1e-2 and below) moves the objective by a
# percent or less and a state by a fraction of its range; above these the two solutions are not two
# approximations of one optimum (:func:`resolution`). Measured on the first mesh (Radau 3, 10 intervals,
# against the pilot), objective / state: swing-up 2.3e-4 / 3.3e-3 and the bang-bang block (5 intervals)
# 4.1e-3 / 0.065, both resolved; four-bar 3.6e-2 / 0.14 and acrobot 0.95 / 0.82, not resolved.
UNRESOLVED_OBJECTIVE = 2e-2
UNRESOLVED_STATE = 0.25


def estimate_error(solution, companion, safety: float = SAFETY, windows=(), switches=()) -> ErrorEstimate:
    """The error estimate of ``solution`` from ``companion`` (the same mesh, higher degrees):
    ``safety`` times their difference, per quantity and per interval of ``solution``'s mesh; with how
    far apart the two are as a whole (:func:`resolution`).

    ``windows``: ``(from, to)`` fractions of the horizon around the jumps of a bang-bang input
    (:func:`.switch_detection.jump_windows`), left out of the multipliers and inputs. There both jump,
    each solution places the jump somewhere in the window, and their difference is the jump itself
    (minimum-time swing-up: 0.2-0.7 of the largest load at every mesh): no mesh removes it unless the
    switch time is a variable. The states, continuous, are compared everywhere, and where the solution
    switches (``switches``, :func:`.switch_detection.detect_switches`) their estimate is at least the
    switch's ``effect``: how far the NLP's speeds are from a clean switch at the located time (the NLP
    smears a jump over its bracket, holding the bounds loosely there, and the companion smears it alike:
    the bang-bang block at 1e-4, true state error 5.9e-6, the companion's difference 2.1e-6, the effect
    1.2e-5). At an input's kink inside an interval the multipliers' and inputs' estimate is at least the
    kink's own size (:func:`_kink_floor`)."""
    fractions, owner = sample_grid(solution.transcription)
    ours, theirs = values_at(solution, fractions), values_at(companion, fractions)
    est = compare(ours, theirs, fractions, owner, solution.transcription.scheme.intervals, names(solution), windows)
    est.objective_change, est.state_change = resolution(solution, companion, ours["states"], theirs["states"])
    est.totals = {q: safety * v for q, v in est.totals.items()}
    est.per_interval = {q: safety * v for q, v in est.per_interval.items()}
    est.local_states = safety * est.local_states
    for w in switches:
        est.per_interval["states"][w.interval] = max(est.per_interval["states"][w.interval], w.effect)
        est.local_states[w.interval] = max(est.local_states[w.interval], w.effect)
        est.totals["states"] = max(est.totals["states"], w.effect)
    _kink_floor(solution, est, switches)
    if solution.transcription.layout.free_time:
        est.totals["t_final"] = safety * abs(solution.t_final - companion.t_final)
    return est


# A degree-p polynomial misses a kink |x| on [-1, 1] by about 0.28 / p at best (Bernstein); a kink of slope change
# s on an interval of length h, at its middle, by about 0.07 s h / p. Collocation is no best approximation: 0.25.
KINK_C = 0.25


def floored_kinks(switches) -> list:
    """The located switches whose interval's estimate :func:`_kink_floor` floors: junctions of an input or a path
    constraint inside an interval (a state's bound is reached tangentially: no kink)."""
    return [w for w in switches if w.kind == "junction" and w.inside and w.source != "state"]


def _kink_floor(solution, est, switches) -> None:
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
    :func:`.switch_detection._junction`, and floored). A state's bound is reached tangentially: its inputs and
    multipliers need not kink."""
    kinks = floored_kinks(switches)
    if not kinks:
        return
    tr = solution.transcription
    mesh, t, T, sample_names = tr.scheme.mesh_fractions, solution.t, solution.t_final, names(solution)
    # Each quantity's values at the points, relative to its scale: read once for all the kinks.
    values = {q: np.array([np.asarray(solution.sample(n), float) for n in sample_names[q]]) / scale
              for q, scale in (("multipliers", est.load_scale), ("inputs", est.input_scale)) if sample_names[q] and scale}
    for w in kinks:
        before, after = np.flatnonzero(t < w.fraction * T)[-2:], np.flatnonzero(t > w.fraction * T)[:2]
        if len(before) < 2 or len(after) < 2:
            continue
        k = w.interval
        reach = KINK_C * (mesh[k + 1] - mesh[k]) * T / len(tr.local[k].tau)
        for q, V in values.items():
            slope = [(V[:, b] - V[:, a]) / (t[b] - t[a]) for a, b in (before, after)]
            model = reach * float(np.abs(slope[1] - slope[0]).max())
            est.per_interval[q][k] = max(est.per_interval[q][k], model)
            est.totals[q] = max(est.totals[q], model)


# An interval whose inputs' or multipliers' last Legendre coefficient, over their largest after the
# mean, is above this fraction of what a unit step between two of its points gives at the least
# (:func:`_step_ratio`), is not smooth. A jump's coefficients do not fall (a step: 0.52 of the
# largest at degree 3, 0.20 at degree 9); a resolved smooth arc's fall geometrically (swing-up at
# 1e-4: at most 0.015 of the step's). Half the step's: no jump passes, a mildly curved degree-3
# interval does (the rolling-disk drive at 1e-3: 0.23 of the step's).
DECAY_LIMIT = 0.5
# Components whose coefficients after the mean are all below this (relative to the quantity's
# largest value) are constant on the interval: their ratios are round-off, not a decay.
NEGLIGIBLE = 1e-6


def _step_ratio(to_coefficients: np.ndarray) -> float:
    """The smallest ``|a_last| / max_{j >= 1} |a_j|`` of a unit step between any two of the points
    (``to_coefficients``: point values to Legendre coefficients): what a jump gives at the least,
    0.52 at degree 3 down to 0.20 at degree 9 (a smooth ``exp(x)`` on the interval: 0.39 and 1e-4)."""
    n = to_coefficients.shape[1]
    steps = (np.arange(n)[None, :] >= np.arange(1, n)[:, None]).astype(float)     # step after point s
    a = np.abs(steps @ to_coefficients.T)
    return float((a[:, -1] / a[:, 1:].max(axis=1)).min())


def legendre_decay(solution) -> tuple[np.ndarray, np.ndarray]:
    """Per interval, the largest over the inputs and over the multipliers of ``max |a_last| / max_{j >= 1} |a_j|``
    (maxima over the quantity's components, in its relative scale) divided by that of a unit step
    (:func:`_step_ratio`), ``a_j`` the Legendre coefficients of the solution's polynomial through the
    interval's collocation points; and that ``max |a_last|``
    (the size of the polynomial's last term, relative to the quantity's largest value). Needs no
    NLP: the coefficients are a linear map of the point values.

    Where the solution is smooth and resolved, the coefficients fall geometrically and this is small;
    where the inputs or multipliers jump inside the interval (a switch), it stays near one, at any
    degree: there a comparison with a higher degree (the companion of :func:`estimate_error`), which
    resolves the jump no better, is not an upper bound of the error (Liu, Hager and Rao 2015 use the
    same decay to tell smooth intervals from non-smooth ones). States are left out: at a switch of a
    bang-bang input they are continuous with their first derivative, and their coefficients fall."""
    from numpy.polynomial import legendre

    tr = solution.transcription
    labels = names(solution)
    out, tail = np.zeros(tr.scheme.intervals), np.zeros(tr.scheme.intervals)
    mesh = tr.scheme.mesh_fractions
    # Intervals of one local scheme share the map from point values to coefficients (their points in
    # local time are the same): one matrix per degree, all their intervals at once.
    local_of = np.array([tr.local[k].label for k in range(tr.scheme.intervals)])
    for q in ("inputs", "multipliers"):
        values = np.array([solution.sample(n) for n in labels[q]]).reshape(len(labels[q]), -1)
        scale = float(np.abs(values[:, 1:]).max()) if values.shape[1] > 1 and values.size else 0.0
        if scale == 0.0:
            continue
        for label in np.unique(local_of):
            ks = np.flatnonzero(local_of == label)
            p = len(tr.interval_points(ks[0]))
            if p < 4:           # fewer than 3 collocation points: no decay to read
                continue
            # Radau's inputs and multipliers at an interval's first point belong to the interval
            # before (its last collocation point): the fit uses the interval's own points.
            idx = tr.offsets[ks][:, None] + np.arange(1, p)[None, :]
            x = 2.0 * (tr.fractions[idx[0]] - mesh[ks[0]]) / (mesh[ks[0] + 1] - mesh[ks[0]]) - 1.0
            to_coefficients = np.linalg.inv(legendre.legvander(x, p - 2))
            a = np.abs(np.einsum("jp,ckp->kjc", to_coefficients, values[:, idx])) / scale   # interval x j x component
            # Tail over the largest variation of any component (one scale for the quantity): a small
            # component's round-off is not read as a slow decay.
            body = a[:, 1:, :].max(axis=(1, 2))
            last = a[:, -1, :].max(axis=1)
            ratio = np.where(body > NEGLIGIBLE, last / np.maximum(body, NEGLIGIBLE), 0.0) / _step_ratio(to_coefficients)
            worse = ratio > out[ks]
            out[ks[worse]], tail[ks[worse]] = ratio[worse], last[worse]
    return out, tail


def predicted_error(solution) -> tuple[np.ndarray, np.ndarray]:
    """Per interval, the error of the solution's polynomials that their own Legendre coefficients predict,
    before any companion is solved: the next coefficient, extrapolated geometrically from the last two,
    ``|a_d| min(1, |a_d| / |a_{d-1}|)`` (maxima over the components; states absolute through the interval's
    points, multipliers relative to their largest value through its collocation points), the larger of the
    two; and whether both fall there (``|a_d| < |a_{d-1}|``). The geometric fall is what hp theory assumes
    of a smooth, resolved solution (Patterson and Rao 2014, Liu, Hager and Rao 2015); where the
    coefficients do not fall (a coarse mesh that does not resolve the solution: the suite's acrobot and
    cart double pendulum on 10 intervals of degree 3, rates up to 1.6-1.9), the prediction means nothing.
    Used only to size the pilot
    (:func:`.mesh_companions.pilot_pieces`), never as the estimate: on the first mesh (Radau 3, 10 intervals)
    the pilot's estimate per interval is 0.08-0.38x the last coefficient alone on the swing-up, 1.1-460x on the
    suite's acrobot, cart double pendulum and four-bar (``python scripts/mesh_refinement_costs.py`` reads the
    same ratio on other meshes): a prediction, good to a factor that the pieces it asks for, about its
    seventh root, mostly absorb."""
    from numpy.polynomial import legendre

    tr = solution.transcription
    labels = names(solution)
    mesh = tr.scheme.mesh_fractions
    out, falls = np.zeros(tr.scheme.intervals), np.ones(tr.scheme.intervals, bool)
    for q in ("states", "multipliers"):
        values = np.array([solution.sample(n) for n in labels[q]]).reshape(len(labels[q]), -1)
        scale = 1.0 if q == "states" else (float(np.abs(values[:, 1:]).max()) if values.size else 0.0)
        if not values.size or scale == 0.0:
            continue
        first = 0 if q == "states" else 1       # multipliers: the interval's own (collocation) points
        for k in range(tr.scheme.intervals):
            idx = np.asarray(tr.interval_points(k))[first:]
            if len(idx) < 3:
                continue
            x = 2.0 * (tr.fractions[idx] - mesh[k]) / (mesh[k + 1] - mesh[k]) - 1.0
            a = np.abs(np.linalg.solve(legendre.legvander(x, len(idx) - 1), values[:, idx].T)).max(axis=1) / scale
            rate = a[-1] / a[-2] if a[-2] > 0 else np.inf
            falls[k] &= rate < 1.0
            out[k] = max(out[k], a[-1] * min(rate, 1.0))
    return out, falls

