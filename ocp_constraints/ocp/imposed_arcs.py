"""A quantity held on its bound over an arc, imposed on the NLP (issue 19; :mod:`.junction_times` finds the arcs' ends).

An input with an effort term (a torque limit on a motor whose ``tau^2`` is minimized) that reaches its bound rides it
over an arc and leaves it continuously, with a kink, at each *junction*; so does a path constraint that moves with
such inputs (a hinge-force bound on that motor's rod, :mod:`.path_regularity`). With the bound as an inequality, two
things keep the NLP about 1e-5 from the optimum, however fine the mesh (the torque-limited rod of
``examples/torque_limited_rod.py``; ``python scripts/junction_at_mesh_point.py``):

- a junction inside a mesh interval, a kink that no polynomial follows;
- IPOPT's barrier on the arc next to a junction: it holds the quantity ``mu / z`` off the bound, and the bound's
  multiplier ``z`` falls to zero at the junction (with mesh points at the exact junctions, the rod's torque there was
  1.2e-5 of the bound short of it, whatever the tolerance asked of the mesh).

So the arc is imposed (:func:`pin_arcs`): the quantity fixed at its bound at the arc's points (an input's variable, a
path constraint's row), its bound dropped over the free interval next to each junction. The junction must then be a
mesh point, and its time is the root of the quantity's continuity mismatch there (:func:`mismatch`): the free side's
polynomial at the junction less the bound (:mod:`.junction_times`). On the rod at 1e-6 the junctions end 7.6e-12 s
from the closed form's and the torque 2.5e-11 of its bound from it, on 51 points
(``python scripts/junction_at_mesh_point.py``).

A bound on a coordinate or a speed (a pendulum lowered onto a stop, Bryson and Denham's wall, a speed limit) is imposed
too (``state``): the state at its bound on the arc's points, its junctions' points included (a state is continuous), its
bound dropped over the free interval next to each junction. A state reaches its bound tangentially, so its own
mismatch has no simple root; but an input with an effort term is continuous at such a junction (its Hamiltonian is
strictly convex in it; Jacobson, Lele and Speyer 1971, for constraints of order one and two), and its jump there, the
free side's value less the arc's (``via``, the input that kinks most there), is the root: Bryson-Denham's
``2 (t1 - 3 l) / t1^2`` for an entry at ``t1`` (the free arc's cubic through the wall's point with zero speed).
With the bound an inequality the same barrier and kink as an input's kept the multipliers about 1e-5 off: an eighth
newcomer's pendulum "met" 1e-5 with its hinge force 2.9x the estimate, entering the stop 3.3e-5 s late
(``scripts/refinement_newcomer8``). A state's arc from ``t0`` or to the end (a motion that starts or ends on the
bound) has one junction; the end's own point is left to the boundary values and the bound's inequality (pinned as
well, the two equalities on one point made the NLP's Jacobian rank-deficient). Until session 31 such arcs were not
imposed: the fourteenth newcomer's block starting at its speed limit was not met at 1e-6 on 245 points; now 61
points from 1e-4 to 1e-7, its error at rounding (``tests/test_refinement_state_arcs.py``). A path constraint of the
states is imposed as a state's bound, on its path rows (``path`` and ``state``): one with the speeds in it as a speed's
(session 31), one of the coordinates alone (order two: a wall, a floor under a foot) as a coordinate's, its rate
``dg/dq N(q) u + dg/dt`` on a free row held at zero at the entry (session 32). The stop pendulum's stop written as
``sin(psi) >= sin 0.5`` was "met" at 1e-6 on 848 points with its hinge force 8.9x the estimate; imposed, 89 points and
0.50 (``python scripts/order_two_paths/run.py pend_sin 1e-6``).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

import numpy as np

from .arc_handoffs import handed_off
from .path_regularity import regular_pieces
from .switch_detection import activity, bounded_quantities, detect_switches, penalized_inputs
from .transcription_elements import path_scale, rate_row, single_speed, state_row


@dataclass(frozen=True)
class Arc:
    """``quantity`` held at ``value`` (one of its bounds) from ``start`` to ``end`` (fractions of the horizon): an input,
    with ``path`` a path constraint (its label), with ``state`` a coordinate or speed, whose junctions are placed by the
    continuity of input ``via``; a start at 0 or an end at 1 is no junction (the arc runs from the start or to the
    end)."""

    quantity: str
    value: float
    start: float
    end: float
    path: bool = False
    state: bool = False
    via: str | None = None
    open_start: bool = False    # the quantity is on its bound before ``start`` too, held there as an inequality: no
    open_end: bool = False      # junction (a path constraint's regular piece, :mod:`.path_regularity`); so after ``end``


# Arcs, junctions and meshes are in fractions of the horizon (``tr.fractions``), so that a free final time stretches
# them with the mesh; EPS: two fractions closer than this are one.
EPS = 1e-9


def _input_columns(tr, name: str) -> np.ndarray:
    """The decision-vector index of input ``name`` at every point."""
    lay = tr.layout
    first = int(np.sum(lay.sizes()[:3]))         # the blocks x, a, lam come before the inputs (.layout)
    r = list(getattr(tr, "user_problem", tr.problem).model.inputs).index(name)
    return first + np.arange(lay.n_points) * lay.n_in + r


def path_rows(tr, label: str) -> np.ndarray | None:
    """The NLP row of path constraint ``label`` at every point, or None where the transcription keeps its path rows
    elsewhere than after each point's position rows (the condensed one)."""
    names = [c.label for c in tr.nlp_path_constraints]
    if label not in names or len(tr.position_rows_at) != tr.layout.n_points:
        return None
    rows = []
    for i in range(tr.layout.n_points):
        element, instance, first = tr.position_rows_at[i]
        if not element.startswith(("point", "collocation_point")):
            return None
        rows.append(tr.block.rows(element, instance) + first + tr.layout.nh + names.index(label))
    return np.asarray(rows)


def on_rows(tr, arc: Arc) -> bool:
    """Whether the arc is held by NLP rows (a path constraint; a state's bound in joint coordinates, where the bodies'
    coordinates are expressions), else by decision variables (an input; a state in maximal coordinates)."""
    return arc.path or (arc.state and any(c.label == state_row(arc.quantity) for c in tr.nlp_path_constraints))


def _row_label(arc: Arc) -> str:
    return state_row(arc.quantity) if arc.state and not arc.path else arc.quantity


def _of_speeds(pr, label: str) -> bool:
    """Whether path constraint ``label`` involves the speeds (its time derivative the accelerations: order one)."""
    c = next(c for c in pr.path_constraints if c.label == label)
    return bool(ca.depends_on(c.expression, pr.eqs.u))


def _path_scale(tr, arc: Arc) -> float:
    return path_scale(next(c for c in tr.nlp_path_constraints if c.label == _row_label(arc)))


def _indices(tr, arc: Arc) -> np.ndarray:
    if on_rows(tr, arc):
        return path_rows(tr, _row_label(arc))
    if arc.state:
        names = tr.problem.model.coordinate_names + tr.problem.model.speed_names
        return names.index(arc.quantity) + np.arange(tr.layout.n_points) * tr.layout.nx
    return _input_columns(tr, arc.quantity)


def is_touch(arc: Arc) -> bool:
    """A state's arc of no length: the bound touched at one instant (module notes)."""
    return arc.state and arc.start == arc.end


def inner_junctions(arcs: list[Arc]) -> list[tuple[int, str, float]]:
    """``(arc, "start" | "end" | "touch", fraction)`` of every inner junction (a touch is one)."""
    out = []
    for k, a in enumerate(arcs):
        ends = (("touch", a.start),) if is_touch(a) else (("start", a.start), ("end", a.end))
        out += [(k, side, at) for side, at in ends if EPS < at < 1.0 - EPS and not getattr(a, f"open_{side}", False)]
    return out


def _free_interval(tr, at: float, side: str) -> np.ndarray:
    """The points of the free interval next to a junction at mesh point ``at``: before an arc's start (up to ``at``,
    which Radau's interval ends on), after an arc's end (``at`` not included)."""
    t, mesh = tr.fractions, tr.scheme.mesh_fractions
    k = int(np.argmin(np.abs(mesh - at)))
    if side == "touch":
        return np.concatenate([_free_interval(tr, at, "start"), _free_interval(tr, at, "end")])
    if side == "start":
        return np.flatnonzero((t > mesh[max(k - 1, 0)] + EPS) & (t <= at + EPS))
    return np.flatnonzero((t > at + EPS) & (t <= mesh[min(k + 1, len(mesh) - 1)] + EPS))


def pinned_points(tr, arcs: list[Arc]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The points each arc fixes (an input's or path constraint's after its start: at an inner start the point is the
    free interval's last, whose value is the mismatch; ``t = 0`` left to Radau's extrapolation; a state's from its start,
    continuous there), and those whose bound each inner junction drops (the free interval next to it, a state's
    junction point not; each junction a mesh point)."""
    t = tr.fractions
    # A state's arc from t0 or to the end leaves that end's point to the boundary values and the bound's inequality.
    fixed = [np.flatnonzero((t > a.start - EPS if a.state and a.start > 0.0 else t > max(a.start, 0.0) + EPS)
                            & (t <= a.end + EPS if not a.state or a.end < 1.0 else t < 1.0 - EPS)) for a in arcs]
    freed = [np.zeros(0, int) if _jump(arcs, k, at) else _free_interval(tr, at, side)
             for k, side, at in inner_junctions(arcs)]
    freed = [p[np.abs(t[p] - at) > EPS] if arcs[k].state else p for (k, _, at), p in zip(inner_junctions(arcs), freed)]
    return fixed, freed


def _jump(arcs: list[Arc], k: int, at: float) -> bool:
    """Whether arc ``k``'s junction at ``at`` is a jump: another arc of its quantity meets it there (a bang-bang input,
    no free interval between its bounds), so both sides stay pinned; its time is then a free mesh point's
    (:mod:`.free_mesh_points`), not a root of a continuity mismatch."""
    return any(j != k and b.quantity == arcs[k].quantity and min(abs(b.start - at), abs(b.end - at)) <= EPS
               for j, b in enumerate(arcs))


def pinned(tr, arcs: list[Arc]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """:func:`pinned_points` as indices: decision variables for an input, NLP rows for a path constraint."""
    fixed, freed = pinned_points(tr, arcs)
    return ([_indices(tr, a)[i] for a, i in zip(arcs, fixed)],
            [_indices(tr, arcs[k])[i] for (k, _, _), i in zip(inner_junctions(arcs), freed)])


def pin_arcs(tr, arcs: list[Arc], lbx: np.ndarray, ubx: np.ndarray, lbg: np.ndarray, ubg: np.ndarray) -> None:
    """Impose ``arcs`` on a transcription's variable and row bounds, in place (:func:`pinned`; a path row holds its
    constraint over :func:`.transcription_elements.path_scale`)."""
    fixed, freed = pinned(tr, arcs)
    junctions = inner_junctions(arcs)
    for a, idx in zip(arcs, fixed):
        lo, hi = (lbg, ubg) if on_rows(tr, a) else (lbx, ubx)
        lo[idx] = hi[idx] = a.value / (_path_scale(tr, a) if on_rows(tr, a) else 1.0)
    for (k, _, _), idx in zip(junctions, freed):
        lo, hi = (lbg, ubg) if on_rows(tr, arcs[k]) else (lbx, ubx)
        lo[idx], hi[idx] = -np.inf, np.inf
    for a in arcs:
        # A coordinate reaches its bound tangentially: its rate is zero at the entry too (the arc's own points have it
        # from their constant polynomial; the entry's rate is the free interval's, which would otherwise arrive at speed
        # and stop within the arc's first interval, its input's jump smeared there: no root).
        rate = entry_rate(tr, a.quantity) if a.state and a.start > 0.0 else None
        if rate is not None:
            at = int(np.argmin(np.abs(tr.fractions - a.start)))
            lo, hi = (lbg, ubg) if rate[0] == "rows" else (lbx, ubx)
            lo[rate[1][at]] = hi[rate[1][at]] = 0.0


def entry_rate(tr, name: str) -> tuple[str, np.ndarray] | None:
    """Where coordinate ``name``'s rate is held at each point: ``("rows", NLP rows)`` (joint coordinates: its free row;
    a path constraint of the coordinates alone: its own), ``("columns", decision variables)`` (maximal coordinates,
    where it is one speed: a translation's), else None (a speed's bound or path constraint, or a maximal angle whose
    rate mixes speeds)."""
    pr = tr.problem
    if any(c.label == rate_row(name) for c in tr.nlp_path_constraints):
        rows = path_rows(tr, rate_row(name))
        return None if rows is None else ("rows", rows)
    if name not in pr.model.coordinate_names:
        return None
    j = single_speed(pr.eqs, pr.model.coordinate_names.index(name))
    if j is None or any(c.label == state_row(name) for c in tr.nlp_path_constraints):
        return None
    return "columns", pr.eqs.nq + j + np.arange(tr.layout.n_points) * tr.layout.nx


def mismatch(solution, arcs: list[Arc], scale: dict[str, float]) -> np.ndarray:
    """Per inner junction (:func:`inner_junctions`' order): the free side's input at the junction less the arc's value,
    over the input's ``scale``: before a start, the free interval's last point (at the junction); after an end, the
    polynomial through the free interval's points, evaluated at the junction. A state's arc: input ``via``'s jump
    there, the free side's value less the arc side's (the point at the junction is the side before it; the other
    side's polynomial through the interval after it, evaluated at the junction)."""
    tr = solution.transcription
    t = tr.fractions
    out = []
    for k, side, at in inner_junctions(arcs):
        a = arcs[k]
        after = _free_interval(tr, at, "end")     # the interval after the junction: the free side's after an end
        if a.state:
            u = np.asarray(solution.sample(a.via), float).ravel()
            here, beyond = u[int(np.argmin(np.abs(t - at)))], _extrapolated(t[after] - at, u[after])
            out.append((beyond - here if side == "end" else here - beyond) / scale[a.via])
            continue
        u = values_of(solution, a)
        value = u[_free_interval(tr, at, side)[-1]] if side == "start" else _extrapolated(t[after] - at, u[after])
        out.append((value - a.value) / scale[a.quantity])
    return np.asarray(out, float)


def _extrapolated(ts: np.ndarray, values: np.ndarray) -> float:
    """The polynomial through ``(ts, values)`` at 0."""
    return float(np.polyval(np.polyfit(ts, values, len(ts) - 1), 0.0))


def values_of(solution, arc: Arc) -> np.ndarray:
    """The arc's quantity at every point of ``solution``."""
    return path_values(solution)[arc.quantity] if arc.path else np.asarray(solution.sample(arc.quantity), float).ravel()


def path_values(solution) -> dict[str, np.ndarray]:
    """Each path constraint's value at every point, by label (kept on the solution)."""
    kept = solution.__dict__.get("_path_values")
    if kept is None:
        kept = solution.__dict__["_path_values"] = {name: v for name, v, *_ in bounded_quantities(solution)}
    return kept


def find_arcs(solution) -> tuple[list[Arc], dict[str, float]]:
    """The arcs on which a quantity that leaves its bound continuously sits at a bound, at two points or more, their ends
    at the located junctions (:func:`.switch_detection.detect_switches`); and each such quantity's scale (its bounds'
    largest magnitude; an input's that places a state's junctions, its bounds' or its largest value). Such a quantity is
    an input with an effort term (:func:`.switch_detection.penalized_inputs`), or where every input has one, a path
    constraint of the inputs or multipliers (the inputs follow the costates continuously, so does the constraint) or a
    coordinate's or speed's bound over an arc (module notes), or a path constraint of the states that involves the
    speeds (as a speed's bound, on its rows) or of the coordinates alone (as a coordinate's, its rate on a free row);
    not a transcription whose path rows are elsewhere (the condensed one)."""
    tr = solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    t = tr.fractions
    smooth, located, arcs, scale, runs_of = None, None, [], {}, []
    for name, v, lo, hi, state, continuous in bounded_quantities(solution):
        # A path constraint of the states that involves the speeds (order one: a joint's speed limit written with
        # subject_to) is a state's bound in all but its rows: imposed as one, on its path rows.
        # One of the coordinates alone (order two: a wall, a floor under a link's tip) is a coordinate's bound in all
        # but its rows: its rate held at the entry on its free "rate of" row (entry_rate).
        of_speeds = continuous and not state and _of_speeds(pr, name)
        of_coordinates = continuous and not state and not of_speeds
        if of_coordinates and entry_rate(tr, name) is None:
            continue
        s, _ = activity(v, lo, hi)
        s[0] = 0                                    # t = 0: Radau's extrapolated input, the multipliers' acceleration level
        if not s.any():
            continue
        if smooth is None:      # only where a quantity reaches a bound (the curvature at every point: ~1 ms)
            smooth = penalized_inputs(solution)
            located = [w for w in detect_switches(solution) if w.kind == "junction"]
        path = not state and name not in pr.model.inputs
        every_input = bool(smooth) and set(smooth) == set(pr.model.inputs)
        if state:
            # A coordinate's arc needs its rate held at the entry (entry_rate); a speed's is held by its own bound.
            on_path_rows = any(c.label == state_row(name) for c in tr.nlp_path_constraints)
            if not every_input or (on_path_rows and path_rows(tr, state_row(name)) is None) or (
                    name in pr.model.coordinate_names and entry_rate(tr, name) is None):
                continue
        elif (name not in smooth) if not path else (not every_input or path_rows(tr, name) is None):
            continue
        path_state = of_speeds or of_coordinates
        state = state or path_state
        runs = np.flatnonzero(np.diff(np.concatenate([[0], (s != 0).astype(int), [0]])))
        for i, j in zip(runs[::2], runs[1::2] - 1):
            if j == i or s[i] != s[j] or np.any(s[i : j + 1] != s[i]):
                continue
            at = [w.fraction for w in located if w.quantity == name]
            if state:
                # Reached tangentially, a state looks active before its junction (within ACTIVE of its scale): the
                # junctions located over the run, its first and last.
                inside = [x for x in at if t[max(i - 1, 0)] <= x <= t[min(j + 1, len(t) - 1)]]
                # From t0 or to the end (a motion that starts or ends at the bound): one junction, the other end none.
                from_start, to_end = i <= 1, j == len(t) - 1
                if (from_start and to_end) or len(inside) < 2 - from_start - to_end:
                    continue
                start = 0.0 if from_start else min(inside)
                end = 1.0 if to_end else max(inside)
                mesh = tr.scheme.mesh_fractions
                if not (from_start or to_end) and np.searchsorted(mesh, start) == np.searchsorted(mesh, end):
                    # Both junctions inside one interval: a touch, its NLP smeared over the interval's points (a
                    # fourth newcomer's cart-pole, whose cart touches its bound once: the secant on an entry and an
                    # exit crossed them over).
                    start = end = 0.5 * (start + end)
                via = _kinking_input(solution, sorted(smooth), end if from_start else start)
                arcs.append(Arc(name, float(lo if s[i] < 0 else hi), start, end, path=path_state, state=True, via=via))
                runs_of.append((i, j))
                scale[name] = _scale(v, lo, hi)
                scale[via] = _input_scale(solution, pr, via)
                continue
            start = 0.0 if i <= 1 else _nearest(at, t[i - 1], t[i])
            end = 1.0 if j == len(t) - 1 else _nearest(at, t[j], t[j + 1])
            points = np.arange(max(i, 1), j + 1)
            pieces = regular_pieces(solution, name, points, start > 0.0, end < 1.0) if path else [(0, len(points) - 1)]
            for first, last in pieces:
                # A piece that stops short of the arc's end (or starts after its start) is open there: the bound
                # holds on as an inequality (.path_regularity).
                a, b = points[first], points[last]
                open_start, open_end = bool(a > points[0]), bool(b < points[-1])
                arcs.append(Arc(name, float(lo if s[i] < 0 else hi), float(0.5 * (t[a - 1] + t[a])) if open_start else start,
                                float(t[b]) if open_end else end, path, open_start=open_start, open_end=open_end))
                runs_of.append((a, b))
                scale[name] = _scale(v, lo, hi)
    return handed_off(arcs, runs_of), scale


def _scale(values: np.ndarray, lo: float, hi: float) -> float:
    """A bounded quantity's scale: its bounds' largest magnitude, else (no bound but zero) its largest value. A bound
    at zero has no magnitude of its own: the walker's centre of pressure (ankle torque less half the foot times the
    normal force, <= 0) scaled by 1e-12 asked its junction's mismatch to 1e-18 N m, below what a junction's time can
    resolve in double precision, and each refinement spent its 12 secant steps in vain (a 240 s cap hit at 1e-4)."""
    bounds = [abs(b) for b in (lo, hi) if np.isfinite(b) and b != 0.0]
    return max(bounds or [float(np.abs(np.asarray(values, float)).max())] + [1e-12])


def _input_scale(solution, pr, name: str) -> float:
    """An input's bounds' largest magnitude, else its largest value on ``solution``."""
    lo, hi = pr.bounds.get(name, (-np.inf, np.inf))
    return _scale(np.asarray(solution.sample(name), float).ravel(), lo, hi)


def _kinking_input(solution, inputs: list[str], at: float) -> str:
    """Of ``inputs``, the one whose slope changes most (relative to its scale) across a junction at fraction ``at``: the
    input the bound acts on, whose jump places the junction best (a steep root)."""
    t, tr = solution.t, solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    before, after = np.flatnonzero(tr.fractions < at)[-2:], np.flatnonzero(tr.fractions > at)[:2]
    if len(inputs) == 1 or len(before) < 2 or len(after) < 2:
        return inputs[0]

    def kink(name):
        u = np.asarray(solution.sample(name), float).ravel() / _input_scale(solution, pr, name)
        return abs((u[after[1]] - u[after[0]]) / (t[after[1]] - t[after[0]]) - (u[before[1]] - u[before[0]]) / (t[before[1]] - t[before[0]]))
    return max(inputs, key=kink)


def _nearest(located: list[float], a: float, b: float) -> float:
    """The located junction between points ``a`` and ``b`` (or nearest to them), else their midpoint."""
    inside = [x for x in located if a - (b - a) <= x <= b + (b - a)]
    return min(inside, key=lambda x: abs(x - 0.5 * (a + b))) if inside else 0.5 * (a + b)
