"""The states' error on a state bound's arc, which the companion shares (ocp/arc_floor.py), against Bryson and Ho's
closed form for Bryson and Denham's block (examples/bryson_denham.py): on the wall the exact block is at x = 1/9 and
at rest, so the NLP's gap from the wall and its speed there are its own errors."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.arc_floor import arc_floor
from ocp_constraints.ocp.switch_detection import detect_switches
from test_refinement_state_arcs import pendulum_on_a_stop

WALL = 1 / 9
EXAMPLE = Path(__file__).parent.parent / "examples" / "bryson_denham.py"


def _bryson_denham(monkeypatch) -> oc.OptimalControlProblem:
    """examples/bryson_denham.py's own problem (its code before the solve): a 1 kg block on a rail, pushed by u,
    x <= 1/9, least integral of u^2."""
    monkeypatch.setattr(sys, "argv", [EXAMPLE.name])      # the example reads its tolerance from sys.argv
    scope: dict = {}
    exec(compile(EXAMPLE.read_text().split("sol = ocp.solve")[0], str(EXAMPLE), "exec"), scope)
    return scope["ocp"]


def _closed_form(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x and v of Bryson and Ho (sec. 3.11) for a wall of 1/9 <= 1/6: on the wall for 1/3 <= t <= 2/3."""
    s = np.minimum(t, 1 - t)
    r = np.where(s < 3 * WALL, 1 - s / (3 * WALL), 0.0)
    return np.where(s < 3 * WALL, WALL * (1 - r ** 3), WALL), r ** 2 * np.where(t <= 0.5, 1.0, -1.0)


def _true_errors(sol, t: np.ndarray) -> float:
    x, v = _closed_form(t)
    return max(float(np.abs(sol.interpolate("block.x", t) - x).max()),
               float(np.abs(sol.interpolate("block.vbar_x", t) - v).max()))


def test_the_floor_on_a_located_arc_is_the_solutions_own_error_at_its_points(monkeypatch):
    # A fixed mesh: no arc imposed, the wall an inequality (where a refinement cannot impose an arc, this floor holds).
    """On each interval wholly on the wall (the junctions located), the floor is the largest of the block's gap from
    the wall and its speed at the interval's points, which is its error there against the closed form; off the arc,
    and on the intervals the junctions lie in, nothing."""
    sol = _bryson_denham(monkeypatch).solve(oc.Radau(mesh=tuple(np.linspace(0.0, 1.0, 13)), degrees=(5,) * 12))
    floor, held = arc_floor(sol, detect_switches(sol))
    assert list(held) == ["block.x"] and held["block.x"] == floor.max()
    mesh, tr = sol.transcription.scheme.mesh_fractions, sol.transcription
    on = np.flatnonzero(floor)
    assert on.size >= 2
    for k in range(len(floor)):
        points = np.asarray(tr.interval_points(k))
        if k in on:
            assert mesh[k] >= 1 / 3 - 1e-3 and mesh[k + 1] <= 2 / 3 + 1e-3
            x, v = _closed_form(sol.t[points])
            truth = max(np.abs(sol.sample("block.x")[points] - x).max(), np.abs(sol.sample("block.vbar_x")[points] - v).max())
            assert floor[k] == pytest.approx(truth, rel=1e-9, abs=1e-15)
        else:
            assert floor[k] == 0.0


def test_bryson_denham_at_1e_6_imposes_the_wall_and_is_exact(monkeypatch):
    """At 1e-6 the block's speed on the wall, 8.7e-8 (IPOPT's gap from the wall varying along it), was 1.40x the
    estimate, since the companion had the same gap; the arc's floor then covered it. Now the arc is imposed
    (ocp/imposed_arcs.py): the block at the wall on its points, its junctions at the roots of the push's jump, which
    are Bryson and Ho's 1/3 and 2/3. The closed form is cubic off the wall, so each interval's polynomial is exact."""
    sol = _bryson_denham(monkeypatch).solve(tolerance=1e-6)
    record = sol.mesh_refinement
    true = _true_errors(sol, np.linspace(0.0, 1.0, 2001))
    assert record["met"]
    [arc] = record["input_arcs"]
    assert arc["quantity"] == "block.x" and arc["state"] and arc["via"] == "u"
    assert arc["start"] == pytest.approx(1 / 3, abs=1e-9) and arc["end"] == pytest.approx(2 / 3, abs=1e-9)
    assert true <= record["estimate"]["states"] and true < 1e-12


def test_a_not_met_message_names_the_arc_whose_floor_holds_the_estimate(monkeypatch):
    """Where the states' estimate above the tolerance is an arc's floor, the message says so (no mesh lowers it);
    where the estimate is above the floor, or the floor under the tolerance, it says nothing of arcs. The floor is
    the one the fixed-mesh solve above measures against the closed form."""
    from ocp_constraints.ocp.error_estimate import SAFETY, estimate_error

    problem = _bryson_denham(monkeypatch)
    sol = problem.solve(oc.Radau(mesh=tuple(np.linspace(0.0, 1.0, 13)), degrees=(5,) * 12))
    companion = problem.solve(oc.Radau(mesh=tuple(np.linspace(0.0, 1.0, 13)), degrees=(7,) * 12))
    switches = detect_switches(sol)
    est = estimate_error(sol, companion, switches=switches)
    floor, _ = arc_floor(sol, switches)
    assert est.arcs == {"block.x": pytest.approx(SAFETY * floor.max())}
    held = est.arcs["block.x"]
    est.totals["states"] = held
    assert "is twice the solution's own error on the arc where 'block.x' holds its bound" in est.arc_note(0.5 * held)
    assert est.arc_note(2.0 * held) == ""
    est.totals["states"] = 2.0 * held
    assert est.arc_note(0.5 * held) == ""


def test_a_state_bounds_junction_put_at_a_mesh_point_floors_the_hinge_forces_estimate():
    """At a stop's entry and exit the hinge force kinks. A junction put at a mesh point may lie anywhere in the half gap
    to the interval's first collocation point, and the interval's polynomial misses the kink by up to the slope
    change times that: the multipliers' estimate is at least that (here computed from the solution's own points,
    two on each side). At 1e-3 the newcomer's true hinge-force error was 1.25x the estimate without it (0.23x with:
    results/bench/refinement_newcomer8.md, follow-up)."""
    from ocp_constraints.ocp.error_estimate import estimate_error

    problem = pendulum_on_a_stop()
    # Mesh points every 0.125 s and at 0.69375 s, near the entry (0.693752 s) and exit (1.375181 s) of the stop.
    mesh = tuple(sorted([*np.linspace(0.0, 1.0, 17), 0.346875]))
    sol = problem.solve(oc.Radau(mesh=mesh, degrees=(5,) * 17))
    companion = problem.solve(oc.Radau(mesh=mesh, degrees=(7,) * 17), warm_start=sol)
    switches = detect_switches(sol)
    at_points = [w for w in switches if w.kind == "junction" and w.source == "state" and not w.inside]
    assert at_points, [(w.kind, w.fraction, w.inside) for w in switches]
    est = estimate_error(sol, companion, switches=switches)
    tr, t, T = sol.transcription, sol.t, sol.t_final
    forces = np.array([sol.sample(f"hinge.{c}.lambda") for c in ("v1", "v2")]) / est.load_scale
    for w in at_points:
        k = w.interval
        half_gap = 0.5 * (tr.fractions[tr.offsets[k] + 1] - tr.scheme.mesh_fractions[k]) * T
        b, a = np.flatnonzero(t < w.fraction * T)[-2:], np.flatnonzero(t > w.fraction * T)[:2]
        change = np.abs((forces[:, a[1]] - forces[:, a[0]]) / (t[a[1]] - t[a[0]])
                        - (forces[:, b[1]] - forces[:, b[0]]) / (t[b[1]] - t[b[0]])).max()
        assert change > 0.0
        assert est.per_interval["multipliers"][k] >= half_gap * change * (1 - 1e-12)
        assert est.totals["multipliers"] >= half_gap * change * (1 - 1e-12)


def _wall_as_a_path_constraint(monkeypatch) -> oc.OptimalControlProblem:
    problem = _bryson_denham(monkeypatch)
    del problem.bounds["block.x"]
    problem.subject_to(problem.quantity("block.x"), upper=WALL, label="wall")
    return problem


def test_the_wall_written_as_a_path_constraint_is_imposed_and_exact(monkeypatch):
    """The same wall as ``subject_to(x, upper=1/9)``, a path constraint of the coordinates alone (order two), is imposed
    as the bound is (since session 32; its rate held at zero at the entry on a free row): the junctions at Bryson and
    Ho's 1/3 and 2/3, the block exact."""
    sol = _wall_as_a_path_constraint(monkeypatch).solve(tolerance=1e-6)
    record = sol.mesh_refinement
    true = _true_errors(sol, np.linspace(0.0, 1.0, 2001))
    assert record["met"]
    [arc] = record["input_arcs"]
    assert arc["quantity"] == "wall" and arc["state"] and arc["path"] and arc["via"] == "u"
    assert arc["start"] == pytest.approx(1 / 3, abs=1e-9) and arc["end"] == pytest.approx(2 / 3, abs=1e-9)
    assert true <= record["estimate"]["states"] and true < 1e-12


@pytest.mark.slow
def test_the_wall_written_as_a_path_constraint_gets_the_same_floor(monkeypatch):
    """Not imposed (its rate row hidden from the refinement), the wall as a path constraint is an inequality: at 1e-6
    the block's speed on the wall was 1.72x the estimate; its rate (dx/dq N u, zero on the arc) over ||dx/dq N||_1
    floors it as the bound's does. The closed form judges it."""
    from ocp_constraints.ocp import imposed_arcs

    entry_rate = imposed_arcs.entry_rate
    monkeypatch.setattr(imposed_arcs, "entry_rate", lambda tr, name: None if name == "wall" else entry_rate(tr, name))
    sol = _wall_as_a_path_constraint(monkeypatch).solve(tolerance=1e-6)
    record = sol.mesh_refinement
    true = _true_errors(sol, np.linspace(0.0, 1.0, 2001))
    assert not record.get("input_arcs")
    assert record["met"] and record["worst"]["states"] == "wall"
    assert 0.1 * record["estimate"]["states"] <= true <= record["estimate"]["states"]
