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

from .arc_floor import arc_floor
from .interpolation import imposed_jumps, interval_of, starts_at_imposed_jumps
from .junction_floors import kink_floor, with_junction_samples

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
    # Per quantity and interval, the part of the difference made there (:func:`made_here`), where
    # ``per_interval`` also holds the error carried in from elsewhere (:meth:`refinement_ratio`).
    local: dict[str, np.ndarray] = field(default_factory=dict)
    # Per quantity held on a located arc (a state bound, a path constraint of the states), the states' floor there
    # (already times SAFETY; .arc_floor), and the states' total without it (what a finer mesh can lower); None where
    # there is no arc.
    arcs: dict[str, float] = field(default_factory=dict)
    mesh_states: float | None = None

    def held_by_arcs(self, tolerance: float, gated) -> str:
        """Why to stop, where only an arc's floor keeps the estimate above ``tolerance`` (no mesh lowers it); else ""."""
        if not self.arcs or self.totals["states"] <= tolerance or self.mesh_states > tolerance or any(
                self.totals[q] > tolerance for q in gated if q != "states"):
            return ""
        return (f"estimate above {tolerance:g} only where a bound on the states holds (states {self.totals['states']:.1e}, "
                f"{self.mesh_states:.1e} from the mesh)")

    def arc_note(self, tolerance: float) -> str:
        """For a message: where the states' estimate above ``tolerance`` is the floor of an arc on a bound (the
        interior point's gap from the bound, which no mesh reduces, :mod:`.arc_floor`), that sentence; else ""."""
        held = {n: v for n, v in self.arcs.items() if tolerance < v >= self.totals["states"]}
        if not held:
            return ""
        name, value = max(held.items(), key=lambda item: item[1])
        return (f"; the states' estimate ({value:.1e}) is twice the solution's own error on the arc where '{name}' "
                f"holds its bound (its gap from the bound, or its rate, exactly 0 on the arc): IPOPT's "
                f"interior point keeps a bound mu/z inside it, by a gap that varies along the arc; the companion has the "
                f"same error, and no mesh reduces it (ocp/arc_floor.py); accept a tolerance above it")

    def as_dict(self) -> dict:
        out = {"estimate": dict(self.totals), "worst": dict(self.worst), "load_scale": self.load_scale,
               "input_scale": self.input_scale}
        if self.objective_change is not None:
            out.update(objective_change=self.objective_change, state_change=self.state_change,
                       resolved=self.resolved)
        return out

    def refinement_ratio(self, tolerance: float, gated) -> np.ndarray:
        """Per interval, the estimate over ``tolerance``, the largest over the ``gated`` quantities: where to refine.

        An optimal control's error is carried along: an error made at one spot (a junction where a path
        constraint becomes active, a kink) shows in the states' difference on every later interval, and, as
        the optimum is a two-point boundary-value problem, in the states and multipliers everywhere (the
        four-bar's pin-force arcs at 1e-3: on 45 intervals the multipliers' difference was above the
        tolerance on 12, the states' change across an interval above 1/44 of the largest on 44, while the part
        made on an interval, :func:`made_here`, singled out the 4-6 that hold the arcs). Refining every
        interval where the error shows refines the whole mesh for an error made at two points. So while a
        quantity's estimate is above the tolerance, its per-interval share is the part made there
        (``local``), scaled so that the largest is the whole estimate: the interval that makes most of the
        error gets the ratio of the whole, the others in proportion to what they make. Met or not is still
        decided on the whole estimate (``totals``), which this leaves as it is."""
        per = dict(self.per_interval)
        for q in gated:
            total, local = self.totals.get(q, 0.0), self.local.get(q)
            if q == "states" and self.mesh_states is not None:
                total = self.mesh_states         # an arc's floor (.arc_floor) is no mesh's to lower
            if local is not None and total > tolerance and local.max() > 0.0:
                per[q] = local * (total / local.max())
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


def values_at(solution, fractions: np.ndarray, probes=None) -> dict[str, np.ndarray]:
    """States (``nx x n``), multipliers and inputs of ``solution`` at normalized times ``fractions``,
    queried by name (:meth:`OCPSolution.polynomial`): the same for a solution of the maximal NLP
    and of the joint-coordinate one, whose states and multipliers are the bodies' (the joints'
    multipliers from their bodies' balances, :mod:`~ocp_constraints.mechanics.generalized`).

    ``probes`` (:func:`inward`): per time, a time just inside the interval meant to read it, so that a time at a
    mesh point reads that interval's limit. After an imposed jump (a bang-bang input's, on a free mesh point:
    :func:`.interpolation.imposed_jumps`) the interval's inputs and multipliers are its own collocation points'
    polynomial, as :meth:`OCPSolution.interpolate` reads them: through its start they bend over the whole jump.
    Elsewhere they keep the start, also where a jump happens to fall on a mesh point: a steep ramp of an input held
    by a small effort term looks so on a coarse mesh (least time plus 1e-6 of effort, the ramp 3e-5 of the horizon
    wide at a mesh point), and read through its start the interval after it shows the solution and its companion
    apart, which asks for the refinement that finds the ramp's arcs; read from its own points both agree to 1e-10
    and the first mesh "met" with the rail's moment off by its whole jump over the ramp."""
    fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
    tr, columns = solution.transcription, solution.sample_columns()
    intervals = None if probes is None else interval_of(tr, probes)
    # One interpolation matrix for every name (OCPSolution.polynomial's, built once: by name it cost ~25 us a name).
    E = tr.interpolation_matrix(fractions, intervals=intervals)
    jumped = starts_at_imposed_jumps(tr)
    E_own = tr.interpolation_matrix(fractions, algebraic=jumped, intervals=intervals) if jumped.any() else E
    return {q: (np.array([columns[n] for n in labels], float).reshape(len(labels), E.shape[1])
                @ (E if q == "states" else E_own).T).reshape(len(labels), fractions.size)
            for q, labels in names(solution).items()}


def inward(fractions: np.ndarray, owner: np.ndarray, mesh: np.ndarray) -> np.ndarray:
    """Each time moved a millionth of the way to the middle of its interval ``owner`` (of ``mesh``): for
    :func:`values_at`, a mesh point read as the end of the interval before or the start of the one after, on
    another mesh too (a companion's free mesh point lies ~1e-12 of the horizon from the solution's)."""
    middle = 0.5 * (mesh[owner] + mesh[owner + 1])
    return fractions + 1e-6 * (middle - fractions)


def truth_samples(solution, per_point: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fractions, their intervals and :func:`inward` probes to compare ``solution`` with a reference on (``per_point``
    per collocation point, read as the estimate reads them); none at the instant of an imposed jump, where the inputs
    and multipliers have two values (each side's is read next to it) and a reference one."""
    fractions, owner = sample_grid(solution.transcription, per_point)
    keep = np.ones(fractions.size, bool)
    for at in imposed_jumps(solution.transcription):
        keep &= np.abs(fractions - at) > 1e-9
    fractions, owner = fractions[keep], owner[keep]
    return fractions, owner, inward(fractions, owner, solution.transcription.scheme.mesh_fractions)


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
    local = {q: made_here((values[q] - reference[q]) / scales[q], fractions, owner, intervals,
                          None if q == "states" else inner, jumps=q != "states") for q in ("states", "multipliers")}
    return ErrorEstimate(totals, per_interval, scales["multipliers"], scales["inputs"], worst, local=local)


def made_here(drift: np.ndarray, fractions: np.ndarray, owner: np.ndarray, intervals: int, valid=None,
              jumps: bool = False) -> np.ndarray:
    """Per interval, the part of a difference ``drift`` (components x samples; ``valid``: the samples to use)
    that the interval makes: its largest departure, over the interval, from its value at the interval's start
    carried on at the rate of its neighbours' background. The background's rate is the rate across a
    neighbouring interval (its last sample less its first, over their distance), of the two neighbours the
    smaller where both change the same way, else none: an error carried in from elsewhere, smooth over a few
    intervals, changes at a rate between its neighbours', and taking the smaller leaves the interval the most
    of what it changes. What an interval adds to the difference, its change across, is counted as made there
    only beyond that rate: an error made at a junction and carried along by the dynamics (a ramp across
    the junction's interval, constant after it: all on that interval), a perturbation of the whole optimum
    (a slope varying smoothly over every interval: little on each), the truncation error of a smooth
    interval (a wave inside it: all of it)."""
    valid = np.ones(fractions.size, bool) if valid is None else np.asarray(valid, bool)
    k = np.arange(intervals)
    starts = np.searchsorted(owner, k, "left")
    own_samples = valid.copy()
    if jumps:       # an interval's first sample, the mesh point, holds the interval before's value
        own_samples[starts[starts < owner.size]] = False
    local = np.zeros(intervals)
    use = np.flatnonzero(own_samples)
    if not drift.size or not use.size:
        return local
    lo, hi = np.searchsorted(owner[use], k, "left"), np.searchsorted(owner[use], k, "right")
    has = hi > lo
    first, last = use[np.minimum(lo, use.size - 1)], use[np.maximum(hi - 1, 0)]
    span = fractions[last] - fractions[first]
    rate = np.where(has & (span > 0), (drift[:, last] - drift[:, first]) / np.where(span > 0, span, 1.0), 0.0)
    before = np.where((k > 0)[None, :], np.roll(rate, 1, axis=1), np.nan)
    after = np.where((k < intervals - 1)[None, :], np.roll(rate, -1, axis=1), np.nan)
    smaller = np.where(np.abs(before) <= np.abs(after), before, after)
    both = np.where(np.sign(before) == np.sign(after), smaller, 0.0)
    background = np.where(np.isnan(before), np.nan_to_num(after), np.where(np.isnan(after), before, both))
    o = owner[use]
    own = drift[:, use] - drift[:, first[o]] - background[:, o] * (fractions[use] - fractions[first[o]])
    np.maximum.at(local, o, np.abs(own).max(axis=0))
    if jumps and intervals > 1:
        # The jump at each inner mesh point: its value (the interval before's) less the interval after's own,
        # extrapolated linearly from its first two samples. Each side made as much of it as its own difference
        # there: a side whose difference is small cannot have made a large jump (the rolling-disk drive's cone
        # junction at 0.05 of the horizon: counted on both sides whole, the interval before it, 2e-5 off its
        # companion, was refined for the junction interval's 3e-4).
        s0 = starts[1:]
        s1, s2 = np.minimum(s0 + 1, owner.size - 1), np.minimum(s0 + 2, owner.size - 1)
        ok = valid[s0] & valid[s1] & valid[s2] & (owner[s2] == k[1:])
        left, right = drift[:, s0], 2.0 * drift[:, s1] - drift[:, s2]
        jump = np.abs(left - right)
        local[:-1] = np.maximum(local[:-1], np.where(ok, np.minimum(jump, np.abs(left)).max(axis=0), 0.0))
        local[1:] = np.maximum(local[1:], np.where(ok, np.minimum(jump, np.abs(right)).max(axis=0), 0.0))
    return local


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


def estimate_error(solution, companion, safety: float = SAFETY, windows=(), switches=(), floor: float = 0.0) -> ErrorEstimate:
    """The error estimate of ``solution`` from ``companion`` (the same mesh, higher degrees):
    ``safety`` times their difference, per quantity and per interval of ``solution``'s mesh; with how
    far apart the two are as a whole (:func:`resolution`).

    ``floor``: the NLP solver's own tolerance (:func:`.mesh_solves.solver_floor`), under which no quantity's
    total is put. Each solve stops that far from its NLP's optimum, so two solves that agree more closely than
    that say nothing of the error: with both solved to 1e-10 the bang-bang block's first mesh (a switch on a mesh
    point) differed from its companion by 2e-12 in the states, its true error was 7e-11
    (``tests/test_mesh_refinement_switches.py``). The floor is at most the smallest tolerance asked (1e-10), so
    "met" and the refinement's choices are the same with it; only the number reported is not below what it can be.

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
    kink's own size (:func:`.junction_floors.kink_floor`); on a located arc of a state bound or a path constraint of the states the
    states' is at least ``safety`` times the solution's own error there (:func:`.arc_floor.arc_floor`: its gap from
    the bound and its rate, which the companion shares)."""
    fractions, owner = with_junction_samples(sample_grid(solution.transcription), solution, companion)
    probes = inward(fractions, owner, solution.transcription.scheme.mesh_fractions)
    ours, theirs = values_at(solution, fractions, probes), values_at(companion, fractions, probes)
    est = compare(ours, theirs, fractions, owner, solution.transcription.scheme.intervals, names(solution), windows)
    est.objective_change, est.state_change = resolution(solution, companion, ours["states"], theirs["states"])
    est.totals = {q: safety * v for q, v in est.totals.items()}
    est.per_interval = {q: safety * v for q, v in est.per_interval.items()}
    est.local = {q: safety * v for q, v in est.local.items()}
    for w in switches:
        est.per_interval["states"][w.interval] = max(est.per_interval["states"][w.interval], w.effect)
        est.local["states"][w.interval] = max(est.local["states"][w.interval], w.effect)
        est.totals["states"] = max(est.totals["states"], w.effect)
    kink_floor(solution, est, switches, names(solution))
    # On an arc of a bound on the states: the interior point's gap from it, which the companion shares (.arc_floor).
    # Only in the total: refinement cannot lower it (ErrorEstimate.refinement_ratio, held_by_arcs).
    _, held = arc_floor(solution, switches)
    est.arcs = {name: safety * value for name, value in held.items()}
    est.mesh_states = est.totals["states"] if est.arcs else None
    for name, value in est.arcs.items():
        if value > est.totals["states"]:
            est.totals["states"], est.worst["states"] = value, name
    if solution.transcription.layout.free_time:
        est.totals["t_final"] = safety * abs(solution.t_final - companion.t_final)
    est.totals = {q: max(v, floor) for q, v in est.totals.items()}
    return est
