"""Accuracy on request (issue 19): hp mesh refinement to a tolerance, its estimate checked against
an independent reference (Pontryagin's conditions by shooting); switches (a closed-form bang-bang
optimum) are tests/test_mesh_refinement_switches.py's."""
from __future__ import annotations

import numpy as np
import pytest

from ocp_constraints.errors import ModelError
from ocp_constraints.ocp.error_estimate import compare, names, sample_grid, values_at
from ocp_constraints.ocp.schemes import Radau, Trapezoidal
from ocp_constraints.scenes.registry import build_task


def _errors(sol, truth) -> dict[str, float]:
    fractions, owner = sample_grid(sol.transcription, 4)
    return compare(values_at(sol, fractions), truth(fractions * sol.t_final), fractions, owner,
                   sol.transcription.scheme.intervals, names(sol)).totals


def _swing_up_truth(ref, sol):
    """The Pontryagin extremal's states (the 12 maximal ones, from psi), multipliers and input at times ``t``."""
    def truth(t):
        psi, w = ref.states(t)
        h, z = ref.L / 2, 0 * t
        lam = ref.multipliers(t)
        return {"states": np.array([h * np.sin(psi), -h * np.cos(psi), z, psi, z, z,
                                    h * w * np.cos(psi), h * w * np.sin(psi), z, z, z, w]),
                "multipliers": np.array([lam[k] for k in names(sol)["multipliers"]]), "inputs": ref.torque(t)[None, :]}
    return truth


@pytest.fixture(scope="module")
def pontryagin():
    """The swing-up's Pontryagin extremal (shooting + DOP853), computed once for both coordinates."""
    from ocp_constraints.bench.references import swing_up_reference

    return swing_up_reference()


@pytest.mark.parametrize("coordinates, nlp", [("auto", "joint"), ("maximal", "maximal")])
def test_estimate_brackets_the_true_error_of_the_swing_up(coordinates, nlp, pontryagin):
    """Swing-up at tolerance 1e-4 from Radau 3 on 10 intervals, in the default coordinates (joint:
    the estimate reads states and multipliers by name, the hinge's from the rod's balance) and in
    maximal ones: against the Pontryagin extremal (shooting + DOP853, all 12 states from psi and
    the hand-written hinge loads) the true error meets the tolerance and lies between a tenth of
    the estimate and the estimate."""
    ref = pontryagin
    _, problem = build_task("pendulum", "swing_up")
    problem.coordinates = coordinates
    sol = problem.solve(Radau(10, degree=3), tolerance=1e-4)
    assert sol.mesh_refinement["coordinates"] == nlp

    truth = _swing_up_truth(ref, sol)

    mr = sol.mesh_refinement
    assert mr["met"] and len(mr["history"]) == mr["refinements"] + 1 >= 2
    if nlp == "joint":
        # Here the last mesh is judged against the pilot, finer everywhere (no companion solved): the
        # bracket below checks that estimate (maximal coordinates: the pilot is taken, its companion solved).
        assert "judged_against" in mr["history"][-1] and mr["history"][-1]["solves"] == 1
    true = _errors(sol, truth)
    for q in ("states", "multipliers"):
        assert true[q] <= 1e-4
        assert mr["estimate"][q] / 10 <= true[q] <= mr["estimate"][q], q
    assert mr["history"][0]["degrees"] == [3] * 10 and mr["degrees"] == [int(d) for d in sol.transcription.scheme.points_per_interval - 1]


def test_bad_tolerance_is_refused_with_its_value():
    _, problem = build_task("pendulum", "swing_up")
    for bad in (0.0, -1e-6, float("nan"), float("inf"), "1e-6", True, [1e-6]):
        with pytest.raises(ModelError, match="tolerance"):
            problem.solve(tolerance=bad)


def test_ipopt_tolerances_looser_than_the_tolerance_are_refused_by_name():
    _, problem = build_task("pendulum", "swing_up")
    with pytest.raises(ModelError, match="'ipopt.tol' 0.0001 is looser than the tolerance 1e-06"):
        problem.solve(tolerance=1e-6, ipopt_options={"ipopt.tol": 1e-4})
    with pytest.raises(ModelError, match="'ipopt.constr_viol_tol' 0.001 is looser"):
        problem.solve(tolerance=1e-4, ipopt_options={"ipopt.constr_viol_tol": 1e-3})


def test_tolerance_needs_a_radau_start_and_the_cli_checks_it(capsys):
    _, problem = build_task("pendulum", "swing_up")
    with pytest.raises(ModelError, match="Radau"):
        problem.solve(Trapezoidal(10), tolerance=1e-4)
    from ocp_constraints.cli.main import main

    assert main(["solve", "pendulum", "--tolerance", "-1"]) == 2
    assert "--tolerance" in capsys.readouterr().err
    assert main(["solve", "pendulum", "--scheme", "trapezoidal", "--tolerance", "1e-4"]) == 2


def test_the_cli_refines_from_the_same_first_mesh_as_the_library(tmp_path):
    """``solve --tolerance`` without --intervals/--degree starts where ``problem.solve(tolerance=...)`` does
    (10 intervals of degree 5); it started from degree 3, so the command refined other meshes than the API
    (the drive at 1e-3: 81 points and a states estimate of 8.7e-4, against 73 points and 1.6e-4)."""
    import json

    from ocp_constraints.cli.main import main

    assert main(["solve", "pendulum", "--tolerance", "1e-4", "--no-plots", "--out", str(tmp_path)]) == 0
    cli = json.loads((tmp_path / "summary.json").read_text())["mesh_refinement"]
    _, problem = build_task("pendulum", "swing_up")
    api = problem.solve(tolerance=1e-4).mesh_refinement
    assert cli["history"][0]["degrees"] == [5] * 10
    assert [h["points"] for h in cli["history"]] == [h["points"] for h in api["history"]]
    assert cli["degrees"] == api["degrees"]


def test_hp_mesh_transcribes_each_interval_with_its_own_degree():
    """Mixed degrees give the points of each interval's Radau scheme, and a uniform ``degrees`` is the
    uniform scheme (same label and NLP)."""
    m = Radau(mesh=(0.0, 0.25, 1.0), degrees=(2, 5))
    assert m.point_count == 2 + 5 + 1 and m.label == "radau2-5"
    assert Radau(3, degrees=(4, 4, 4)) == Radau(3, degree=4)
    with pytest.raises(ModelError, match="degrees"):
        Radau(2, degrees=(3,))


def test_unresolved_comparison_is_recognised_by_objective_or_state_range():
    """resolution(): the objectives' relative difference and the largest state difference over that
    state's range, by hand: J = 1.8 against 40 is 0.955 apart; a state moving over [0, 2] that differs by
    0.6 is 0.3 of its range; a constant state (no range) is left out."""
    from types import SimpleNamespace

    from ocp_constraints.ocp.error_estimate import UNRESOLVED_OBJECTIVE, UNRESOLVED_STATE, ErrorEstimate, resolution

    ref = np.array([[0.0, 1.0, 2.0], [5.0, 5.0, 5.0]])
    ours = ref + np.array([[0.0, 0.6, 0.0], [0.0, 3.0, 0.0]])
    obj, state = resolution(SimpleNamespace(objective=1.8), SimpleNamespace(objective=40.0), ours, ref)
    assert obj == pytest.approx(38.2 / 40.0) and state == pytest.approx(0.3)
    est = ErrorEstimate({}, {}, 1.0, 1.0, objective_change=obj, state_change=state)
    assert not est.resolved and obj > UNRESOLVED_OBJECTIVE and state > UNRESOLVED_STATE
    assert ErrorEstimate({}, {}, 1.0, 1.0, objective_change=1e-4, state_change=1e-3).resolved


def test_a_states_error_made_on_one_interval_and_carried_along_is_refined_where_it_is_made():
    """compare() and ErrorEstimate.refinement_ratio on differences written by hand: a state's difference is 0
    before t = 0.3, grows linearly to 1e-3 across interval 3 (0.3-0.4) and stays 1e-3 after it (an error made
    at a junction and carried along by the dynamics). The estimate is 1e-3 on intervals 3-9, but only interval 3
    makes it: above the tolerance 1e-4 it alone gets the ratio of the whole (10), the carrying intervals none.
    A second state whose difference oscillates with the same amplitude on every interval spreads the ratio
    over all of them. Met states keep their per-interval estimate."""
    from ocp_constraints.ocp.error_estimate import compare

    mesh = np.linspace(0.0, 1.0, 11)
    fractions = np.concatenate([np.linspace(a, b, 5) for a, b in zip(mesh[:-1], mesh[1:])])
    owner = np.repeat(np.arange(10), 5)
    carried = 1e-3 * np.clip((fractions - 0.3) / 0.1, 0.0, 1.0)
    zero = {"multipliers": np.zeros((1, fractions.size)), "inputs": np.zeros((1, fractions.size))}
    labels = {"states": ["x"], "multipliers": ["c.lambda"], "inputs": ["u"]}
    est = compare({"states": carried[None, :], **zero}, {"states": np.zeros((1, fractions.size)), **zero},
                  fractions, owner, 10, labels)
    assert est.totals["states"] == pytest.approx(1e-3)
    assert np.allclose(est.per_interval["states"], [0, 0, 0, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3])
    assert np.allclose(est.local["states"], [0, 0, 0, 1e-3, 0, 0, 0, 0, 0, 0])
    assert np.allclose(est.refinement_ratio(1e-4, ("states",)), [0, 0, 0, 10, 0, 0, 0, 0, 0, 0])
    # Met: the per-interval estimate itself (every ratio at most 1).
    assert np.allclose(est.refinement_ratio(2e-3, ("states",)), est.per_interval["states"] / 2e-3)
    wave = 1e-3 * np.sin(2 * np.pi * 10 * fractions)        # one period per interval: made everywhere
    est = compare({"states": wave[None, :], **zero}, {"states": np.zeros((1, fractions.size)), **zero},
                  fractions, owner, 10, labels)
    assert np.allclose(est.refinement_ratio(1e-4, ("states",)), 10.0)


def test_an_error_carried_over_the_whole_horizon_is_refined_where_it_is_made_not_where_it_shows():
    """made_here and refinement_ratio on a difference written by hand, as an optimum shows it: a smooth perturbation
    of the whole solution (1e-3 (1 + sin(pi t)), what resolving one spot better moves everywhere: the two-point
    boundary-value problem's response) plus a wave of 1e-3 inside interval 12 of 20 alone (a poorly resolved arc),
    sampled as the estimate samples degree 8 (17 samples per interval). On the states and, relative to the largest
    load, on the multipliers, the difference is above the tolerance 2e-4 on every interval, but only interval 12
    makes more than a small part of it: there the ratio is the whole estimate's (14.7), elsewhere below 1 (not
    refined). The states' change across an interval, the share before, gave 13 of the other 19 intervals ratios
    above 1 (up to 2.2), and the multipliers had no share of their own: every interval refined."""
    from ocp_constraints.ocp.error_estimate import compare, made_here

    n = 20
    mesh = np.linspace(0.0, 1.0, n + 1)
    fractions = np.concatenate([np.linspace(a, b, 17) for a, b in zip(mesh[:-1], mesh[1:])])
    owner = np.repeat(np.arange(n), 17)
    made = np.where(owner == 12, 1e-3 * np.sin(2 * np.pi * (fractions - mesh[owner]) * n), 0.0)
    drift = 1e-3 * (1.0 + np.sin(np.pi * fractions)) + made
    local = made_here(drift[None, :], fractions, owner, n)
    assert local.argmax() == 12 and np.all(np.delete(local, 12) < 0.03 * local[12])
    labels = {"states": ["x"], "multipliers": ["c.lambda", "d.lambda"], "inputs": ["u"]}
    load, zero, one = 100.0, np.zeros((1, fractions.size)), np.ones(fractions.size)
    # The multipliers' difference in N, relative to the largest load (100 N); a second constraint's load is exact.
    ours = {"states": drift[None, :], "multipliers": np.vstack([load * (1.0 + drift), one]), "inputs": zero}
    ref = {"states": zero, "multipliers": np.vstack([load * one, one]), "inputs": zero}
    est = compare(ours, ref, fractions, owner, n, labels)
    for q in ("states", "multipliers"):
        assert np.all(est.per_interval[q] > 2e-4)
        ratio = est.refinement_ratio(2e-4, (q,))
        assert ratio[12] == pytest.approx(est.totals[q] / 2e-4, rel=1e-6) and ratio[12] > 14.0
        assert np.all(np.delete(ratio, 12) < 1.0)


def test_a_multipliers_jump_at_a_mesh_point_is_counted_on_the_side_that_made_it():
    """made_here with ``jumps``, on a multipliers' difference written the way Radau holds it (an interval's first
    sample, the mesh point, is the interval before's last collocation value): interval 3 of 10 is off by 1e-3 as a
    whole, a constant offset its own samples do not show, so it jumps at both of its mesh points. Interval 3 made
    both jumps and is credited 1e-3; intervals 2 and 4, whose own differences are 0, are credited nothing."""
    from ocp_constraints.ocp.error_estimate import made_here

    mesh = np.linspace(0.0, 1.0, 11)
    fractions = np.concatenate([np.linspace(a, b, 9) for a, b in zip(mesh[:-1], mesh[1:])])
    owner = np.repeat(np.arange(10), 9)
    drift = np.where(owner == 3, 1e-3, 0.0)
    drift[np.searchsorted(owner, 3)] = 0.0          # interval 3's mesh point: interval 2's value
    drift[np.searchsorted(owner, 4)] = 1e-3         # interval 4's mesh point: interval 3's value
    local = made_here(drift[None, :], fractions, owner, 10, jumps=True)
    assert local == pytest.approx([0, 0, 0, 1e-3, 0, 0, 0, 0, 0, 0], abs=1e-15)


def test_a_warm_solve_ended_at_ipopts_acceptable_level_is_solved_again_from_the_guess(monkeypatch):
    """mesh_solves.timed_solve with a transcription whose solves are scripted: a warm solve that IPOPT ends at its
    acceptable level is solved again from the problem's guess (warm start None, the fallback options); that solution
    is kept where it converges to the same optimum (recorded in ``warm_retry``), else the acceptable one is, and
    Ctrl-C during the second solve is not swallowed."""
    from types import SimpleNamespace

    import ocp_constraints.ocp.mesh_solves as ms
    from ocp_constraints.errors import OCPSolveError

    def outcome(status, objective=1.0, iterations=5):
        return SimpleNamespace(status=status, objective=objective, iterations=iterations)

    def run(second):
        calls = []

        class Scripted:
            def solve(self, options, warm_start, progress=None, scale_objective=False):
                calls.append((options, warm_start))
                result = outcome(ms.ACCEPTABLE, iterations=16) if len(calls) == 1 else second
                if isinstance(result, Exception):
                    raise result
                return result

        monkeypatch.setattr(ms, "build_mesh", lambda *args: Scripted())
        sol, _, _ = ms.timed_solve(None, None, {"warm": 1}, "start", False, fallback={"own": 1})
        return sol, calls

    converged = outcome("Solve_Succeeded", objective=1.001, iterations=21)
    sol, calls = run(converged)
    assert sol is converged and calls == [({"warm": 1}, "start"), ({"own": 1}, None)]
    assert sol.warm_retry["status"] == ms.ACCEPTABLE and ms.iterations(sol) == 21 + 16
    elsewhere = outcome("Solve_Succeeded", objective=1.05)       # another optimum: 5% apart
    assert run(elsewhere)[0].status == ms.ACCEPTABLE
    assert run(outcome(ms.ACCEPTABLE))[0].iterations == 16
    assert run(OCPSolveError("failed", outcome("Maximum_Iterations_Exceeded")))[0].status == ms.ACCEPTABLE
    with pytest.raises(OCPSolveError):
        run(OCPSolveError("stopped", outcome("interrupted by Ctrl-C")))


def test_unresolved_step_halves_the_companion_and_rough_needs_a_non_smooth_interval():
    """uniform_step halves every interval of the companion at its degrees capped at MAX_DEGREE; refine
    splits at MIN_DEGREE an interval whose estimate fell less than tenfold only where it is not smooth,
    else it raises the degree (a fall of 4x per degree: ratio 50 at degree 5 asks for 5 + 3 = 8 > 7,
    so a split at 7 into ceil((50 / 16)^(1/7)) = 2 pieces)."""
    from ocp_constraints.ocp.mesh_refinement import MAX_DEGREE, MIN_DEGREE, _ends, refine, uniform_step

    step = uniform_step(Radau(mesh=(0.0, 0.25, 1.0), degrees=(9, 5)))
    assert list(step.mesh_fractions) == [0.0, 0.125, 0.25, 0.625, 1.0]
    assert list(step.points_per_interval - 1) == [MAX_DEGREE, MAX_DEGREE, 5, 5]
    scheme = Radau(mesh=(0.0, 0.5, 1.0), degrees=(5, 5))
    parents = {_ends(0.0, 0.5): 60.0, _ends(0.5, 1.0): 60.0}
    new, _ = refine(scheme, np.array([50.0, 50.0]), parents, nonsmooth=np.array([True, False]))
    assert list(new.mesh_fractions) == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert list(new.points_per_interval - 1) == [MIN_DEGREE, MIN_DEGREE, MAX_DEGREE, MAX_DEGREE]


def test_a_solution_judges_another_mesh_only_where_it_halves_each_interval_or_raises_its_degree_by_two():
    """finer(), by hand: the pilot (every interval halved at degree 7) judges a mesh of degrees 3 and 6;
    the same intervals judge only at two degrees more; a cut at 0.3 of a 0.5 interval is no half (at one degree
    more); equal
    intervals at equal degrees, or a mesh point missing, never judge."""
    from ocp_constraints.ocp.mesh_companions import finer, pilot_of

    coarse = Radau(mesh=(0.0, 0.5, 1.0), degrees=(3, 6))
    assert finer(coarse, pilot_of(coarse))
    assert finer(coarse, Radau(mesh=(0.0, 0.5, 1.0), degrees=(5, 8)))
    assert not finer(coarse, Radau(mesh=(0.0, 0.5, 1.0), degrees=(5, 7)))
    assert not finer(coarse, Radau(mesh=(0.0, 0.3, 0.5, 1.0), degrees=(4, 4, 8)))
    assert not finer(Radau(mesh=(0.0, 0.25, 0.5, 1.0), degrees=(7, 7, 7)), pilot_of(coarse))
    assert not finer(coarse, Radau(mesh=(0.0, 1.0), degrees=(9,)))


def test_a_raised_degree_is_rounded_up_to_one_whose_element_kinds_the_refinement_has_built():
    """refine with ``built``: ratio 16 at degree 3 asks for 3 + 2 = 5; with degrees 3 and 7 built it gets 7 (no new
    element kinds), with 3 and 6 built 6, with none above 5 built 5; never above MAX_DEGREE (9 built: 5)."""
    from ocp_constraints.ocp.mesh_companions import reused_degree
    from ocp_constraints.ocp.mesh_refinement import refine

    scheme = Radau(mesh=(0.0, 0.5, 1.0), degrees=(3, 3))
    for built, degree in (({3, 7}, 7), ({3, 6, 7}, 6), ({3, 4}, 5), (set(), 5), ({3, 9}, 5)):
        new, _ = refine(scheme, np.array([16.0, 0.5]), built=built)
        assert list(new.points_per_interval - 1) == [degree, 3] and list(new.mesh_fractions) == [0.0, 0.5, 1.0]
        assert reused_degree(5, built) == degree


def test_a_pilot_sized_from_the_first_solution_is_the_final_mesh_at_1e_8_and_its_estimate_brackets_the_truth(pontryagin):
    """Swing-up at 1e-8 (joint coordinates): the first solution's Legendre coefficients fall on every interval,
    so the pilot is cut as finely as they predict a halving will not do (pilot_pieces: 3-4 pieces here, not
    2), the next mesh asks for no more than it (as_fine), and it is the final mesh: 3 solves (the first mesh,
    the pilot, its companion). Against the Pontryagin extremal the true error meets 1e-8 and lies between a
    tenth of the estimate and the estimate."""
    ref = pontryagin
    sol = build_task("pendulum", "swing_up")[1].solve(tolerance=1e-8)
    mr = sol.mesh_refinement
    assert mr["met"] and [h["solves"] for h in mr["history"]] == [2, 1]
    assert mr["history"][1].get("solved_as_companion") and sol.transcription.scheme.intervals > 20

    truth = _swing_up_truth(ref, sol)

    true = _errors(sol, truth)
    for q in ("states", "multipliers"):
        assert true[q] <= 1e-8
        assert mr["estimate"][q] / 10 <= true[q] <= mr["estimate"][q], q


def test_the_pilot_cuts_each_interval_as_asked_and_as_fine_compares_lengths_and_degrees_not_mesh_points():
    """pilot_of with pieces [2, 3] on (0, 0.5, 1): points 0.25 and 0.5 + 0.5/3, 0.5 + 1/3, all at MAX_DEGREE;
    as_fine by hand: a mesh cut in 4 asks for at least what one cut in 3 does (its points are not the
    other's, so covered() says no), one cut in 2 does not, nor one of a lower degree."""
    from ocp_constraints.ocp.mesh_companions import MAX_DEGREE, as_fine, covered, pilot_of

    pilot = pilot_of(Radau(mesh=(0.0, 0.5, 1.0), degrees=(3, 3)), [2, 3])
    assert np.allclose(pilot.mesh_fractions, [0.0, 0.25, 0.5, 0.5 + 0.5 / 3, 0.5 + 1 / 3, 1.0])
    assert list(pilot.points_per_interval - 1) == [MAX_DEGREE] * 5
    thirds = Radau(mesh=tuple(np.linspace(0.0, 1.0, 4)), degrees=(7, 7, 7))
    quarters = Radau(mesh=tuple(np.linspace(0.0, 1.0, 5)), degrees=(7,) * 4)
    assert as_fine(thirds, quarters) and not covered(thirds, quarters)
    assert not as_fine(thirds, Radau(mesh=(0.0, 0.5, 1.0), degrees=(9, 9)))
    assert not as_fine(thirds, Radau(mesh=tuple(np.linspace(0.0, 1.0, 5)), degrees=(7, 6, 7, 7)))
    assert as_fine(thirds, thirds)


def test_ctrl_c_while_a_mesh_is_built_keeps_the_last_complete_solution(monkeypatch):
    """Ctrl-C outside IPOPT (a mesh's NLP being built, or its functions compiled: seconds on a heavy model) ends
    the refinement with an OCPSolveError that keeps the last solution judged, its record saying so."""
    import ocp_constraints.ocp.mesh_refinement as mr
    import ocp_constraints.ocp.mesh_solves as ms
    from ocp_constraints.errors import OCPSolveError

    builds, real = [], ms.build_mesh

    def build(*args, **kwargs):
        builds.append(args[1])
        if len(builds) == 3:                # the first mesh and its pilot built and solved; then Ctrl-C
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(ms, "build_mesh", build)
    problem = build_task("pendulum", "swing_up")[1]
    with pytest.raises(OCPSolveError, match="interrupted during refinement 1, outside IPOPT") as caught:
        mr.solve_to_tolerance(problem, 1e-9, Radau(4, degree=3))
    kept = caught.value.solution
    assert kept is not None and kept.success
    # The first mesh's: the last solution judged (its estimate, from the pilot, is the record's).
    assert kept.transcription.scheme.mesh_fractions.tolist() == builds[0].mesh_fractions.tolist()
    assert kept.mesh_refinement["estimate"] == kept.mesh_refinement["history"][0]["estimate"]
    assert "interrupted" in kept.mesh_refinement["message"]


def test_a_first_mesh_whose_companion_fails_is_returned_not_met_with_no_estimate(monkeypatch, tmp_path, capsys):
    """The first mesh solves, its companion does not (here: every warm solve and its retry capped at one IPOPT
    iteration; a seventh newcomer's URDF arm, whose coarse first solution is far from the finer mesh's optimum):
    ``solve`` returns the first mesh's solution, "met" False, ``estimate`` None, and says why and what to do. Before,
    it raised the companion's OCPSolveError, whose ``.solution`` was the companion's unconverged last iterate. The
    solution returned is checked against a plain fixed-mesh solve of the same first mesh; the CLI prints it too."""
    import json

    import ocp_constraints.ocp.mesh_refinement as mr
    from ocp_constraints.cli.main import main

    fixed = build_task("pendulum", "swing_up")[1].solve(Radau(10, degree=5))
    for name, value in (("WARM_FACTOR", 0), ("WARM_MIN_ITER", 1), ("FALLBACK_FACTOR", 0), ("FALLBACK_MIN_ITER", 1)):
        monkeypatch.setattr(mr, name, value)
    sol = build_task("pendulum", "swing_up")[1].solve(tolerance=1e-6)
    record = sol.mesh_refinement
    assert sol.success and not record["met"] and record["estimate"] is None and record["refinements"] == 0
    assert sol.transcription.scheme.point_count == fixed.transcription.scheme.point_count == 51
    assert sol.objective == pytest.approx(fixed.objective, rel=1e-8)
    assert np.allclose(sol.sample("motor"), fixed.sample("motor"), atol=1e-6 * np.abs(fixed.sample("motor")).max())
    assert "Maximum_Iterations_Exceeded" in record["history"][0]["failed"] and record["history"][0]["solves"] == 1
    assert "its error NOT estimated" in record["message"] and "start from a finer mesh" in record["message"]
    # started again from the problem's guess and perturbed ones (mesh_progress.restarted), under the same cap: none solved
    assert "Started again from the problem's guess and perturbed ones: none solved" in record["message"]
    assert f"none of the {mr.RESTART_STARTS} starts succeeded" in record["message"] and "restarted" not in record
    assert main(["solve", "pendulum", "--tolerance", "1e-6", "--no-plots", "--out", str(tmp_path / "run")]) == 0
    assert "refinements, 10 intervals of degrees 5-5; error NOT estimated" in capsys.readouterr().out
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["mesh_refinement"]["estimate"] is None


def test_a_first_mesh_whose_companion_fails_is_started_again_from_a_multistart_and_refined_from_its_best(monkeypatch,
                                                                                                     pontryagin):
    """The swing-up's first mesh solves, its pilot (warm, and its retry) is made to fail: the refinement starts again
    from the problem's guess and perturbed ones (mesh_progress.restarted: a multi-start on the first mesh at degree 3),
    and refines from the best start, its time counted. The result is checked against the Pontryagin extremal, not
    against a run of the library: true error within the tolerance."""
    import ocp_constraints.ocp.mesh_refinement as mr
    from ocp_constraints.ocp.mesh_companions import low_degree

    solves, real = [], mr._timed_solve

    def timed_solve(problem, scheme, ipopt_options, warm_start, progress, first=None, fallback=None, scale=False, arcs=()):
        solves.append(scheme)
        if len(solves) == 2:        # the first mesh's pilot, warm: stopped after one iteration, its retry too
            ipopt_options = {**ipopt_options, "ipopt.max_iter": 1}
            fallback = {**(fallback or {}), "ipopt.max_iter": 1}
        return real(problem, scheme, ipopt_options, warm_start, progress, first, fallback, scale, arcs)

    monkeypatch.setattr(mr, "_timed_solve", timed_solve)
    sol = build_task("pendulum", "swing_up")[1].solve(tolerance=1e-4)
    record = sol.mesh_refinement
    starts = record["restarted"]["multistart"]
    assert starts["starts"] == mr.RESTART_STARTS and starts["succeeded"] >= 1
    assert record["restarted"]["solution"]["points"] == 51 and "did not resolve the motion" in record["message"]
    # the refinement went on from the best start, on the first mesh at degree 3
    assert record["history"][0]["points"] == low_degree(Radau(10, degree=5)).point_count == 61
    assert record["history"][0]["objective"] == pytest.approx(starts["optima"][0]["objective"], rel=1e-12)
    assert record["met"] and record["total_cpu_s"] > sum(h["cpu_s"] for h in record["history"])
    true = _errors(sol, _swing_up_truth(pontryagin, sol))
    assert max(true["states"], true["multipliers"]) <= 1e-4


def test_a_warm_solve_stopped_at_its_iteration_cap_is_solved_again_with_ipopts_own_options(monkeypatch):
    """With the warm solves' cap forced to one IPOPT iteration, every warm attempt stops there
    (Maximum_Iterations_Exceeded) and is solved again from the same start with the user's options (IPOPT's own):
    the history names each retry and counts its iteration, and the refinement ends on the meshes and estimates of
    a run without the cap (the same optimum, solved to IPOPT's tolerance)."""
    import ocp_constraints.ocp.mesh_refinement as mr

    plain = build_task("pendulum", "swing_up")[1].solve(tolerance=1e-6).mesh_refinement
    monkeypatch.setattr(mr, "WARM_FACTOR", 0)
    monkeypatch.setattr(mr, "WARM_MIN_ITER", 1)
    capped = build_task("pendulum", "swing_up")[1].solve(tolerance=1e-6).mesh_refinement
    assert capped["met"] and capped["mesh"] == plain["mesh"] and capped["degrees"] == plain["degrees"]
    for q in ("states", "multipliers"):
        assert capped["estimate"][q] == pytest.approx(plain["estimate"][q], rel=1e-3)
    retries = [r for h in capped["history"] for r in h.get("warm_retries", [])]
    assert len(retries) == sum(h["solves"] for h in capped["history"]) - 1      # every solve but the first, cold
    assert all(r["status"] == "Maximum_Iterations_Exceeded" and r["iterations"] == 1 for r in retries)
    assert not any("warm_retries" in h for h in plain["history"])


def test_a_mesh_ipopt_cannot_solve_stops_the_refinement_with_the_last_estimated_solution(monkeypatch):
    """The third solve (the first after refinement 0's estimate) and every later one capped at one IPOPT iteration,
    warm attempt and retry alike: IPOPT really stops (Maximum_Iterations_Exceeded); the refinement stops there, 'met'
    False. Refinement 0's estimate being far above the tolerance, that mesh is solved once more from the problem's
    guess and perturbed ones (mesh_progress.restarted: a multi-start, capped too, fails); refinement 0's solution is
    returned with its own estimate and a message saying what failed and what is returned."""
    import ocp_constraints.ocp.mesh_refinement as mr

    solves, real, real_starts = [], mr._timed_solve, mr.solve_multistart

    def solve_multistart(problem, method, starts, seed, client, ipopt_options, *args, **kwargs):
        solves.append(method)
        return real_starts(problem, method, starts, seed, client, {**ipopt_options, "ipopt.max_iter": 1}, *args, **kwargs)

    def timed_solve(problem, scheme, ipopt_options, warm_start, progress, first=None, fallback=None, scale=False, arcs=()):
        solves.append(scheme)
        if len(solves) >= 3:
            ipopt_options = {**ipopt_options, "ipopt.max_iter": 1}
            fallback = {**(fallback or {}), "ipopt.max_iter": 1}
        return real(problem, scheme, ipopt_options, warm_start, progress, first, fallback, scale, arcs)

    monkeypatch.setattr(mr, "_timed_solve", timed_solve)
    monkeypatch.setattr(mr, "solve_multistart", solve_multistart)
    sol = mr.solve_to_tolerance(build_task("pendulum", "swing_up")[1], 1e-9, Radau(4, degree=3))
    record = sol.mesh_refinement
    assert len(solves) == 4 and solves[3].mesh_fractions.tolist() == solves[0].mesh_fractions.tolist()     # at degree 3
    assert not record["met"] and "restarted" not in record
    assert sol.success and sol.transcription.scheme.mesh_fractions.tolist() == solves[0].mesh_fractions.tolist()
    assert record["estimate"] == record["history"][0]["estimate"]
    assert "Maximum_Iterations_Exceeded" in record["history"][1]["failed"]
    assert record["message"].startswith("stopped at refinement 1") and "solution of refinement 0 (4 intervals" in record["message"]
    # an estimate far above the tolerance: the first mesh does not resolve the motion, and the advice says so
    assert record["estimate"]["states"] > 100 * 1e-9
    assert "start from a finer mesh, e.g. solve(oc.Radau(16, degree=5), tolerance=...)" in record["message"]
    assert "Started again from the problem's guess and perturbed ones: none solved" in record["message"]



def test_a_push_that_saturates_meets_1e_6_against_its_closed_form_with_the_refinements_own_complementarity():
    """A newcomer's block (2 kg on a rail, 1 m rest to rest in 1 s, min int F^2, |F| <= 10 N): the optimal push is
    F = sat(c (T/2 - t)), c from x(T) = 1 by bisection on a 200,001-point quadrature (independent of the library).
    With IPOPT's own complementarity tolerance (1e-4) the interior point rounds the corners where F reaches its bound
    and the refinement at 1e-6 ended "not met" (22 solves); at a tolerance of 1e-4 or below the refinement's warm
    solves now ask IPOPT for 1e-14 (mesh_solves.complementarity_tolerance), recorded in the history: met, the states'
    true error inside [0.1, 1] of the estimate, the push within 1e-5 N. Those solves also turn MUMPS's scaling off
    (mesh_solves.without_mumps_scaling). A user's own compl_inf_tol and mumps_scaling are kept, and above 1e-4
    IPOPT's own hold."""
    import casadi as ca
    from scipy.optimize import brentq

    import ocp_constraints as oc

    m, d, T, fmax = 2.0, 1.0, 1.0, 10.0
    model = oc.Model("block", gravity=(0.0, -9.81, 0.0))
    block = model.add_body("block", m, np.diag([0.1, 0.2, 0.3]), rotation="321")
    oc.joints.prismatic(model, "rail", block.com, axis=(1.0, 0.0, 0.0))
    model.add_force("push", block.com, ca.vertcat(model.add_input("F"), 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=T)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
    ocp.final({"block.x": d, "block.vbar_x": 0.0})
    ocp.bound("F", -fmax, fmax)
    ocp.minimize_effort(["F"])

    tt = np.linspace(0.0, T, 200_001)
    c = brentq(lambda c: np.trapezoid((T - tt) * np.clip(c * (T / 2 - tt), -fmax, fmax) / m, tt) - d, 1.0, 1e3,
               xtol=1e-14)
    push = np.clip(c * (T / 2 - tt), -fmax, fmax)
    v = np.concatenate([[0.0], np.cumsum((push[1:] + push[:-1]) / 2 * np.diff(tt))]) / m
    x = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(tt))])

    sol = ocp.solve(tolerance=1e-6)
    mr = sol.mesh_refinement
    assert mr["met"], mr["message"]
    assert mr["complementarity_tolerance"] == 1e-14
    grid = np.linspace(0.0, T, 2001)
    states = max(np.abs(sol.interpolate("block.x", grid) - np.interp(grid, tt, x)).max(),
                 np.abs(sol.interpolate("block.vbar_x", grid) - np.interp(grid, tt, v)).max())
    assert 0.1 * mr["estimate"]["states"] <= states <= mr["estimate"]["states"] <= 1e-6
    assert np.abs(sol.sample("F") - np.clip(c * (T / 2 - sol.t), -fmax, fmax)).max() <= 1e-5
    assert "complementarity_tolerance" not in ocp.solve(tolerance=1e-6, ipopt_options={"ipopt.compl_inf_tol": 1e-13},
                                                        max_refinements=0).mesh_refinement
    at_1e_4 = ocp.solve(tolerance=1e-4, max_refinements=0).mesh_refinement
    assert at_1e_4["complementarity_tolerance"] == 1e-14 and at_1e_4["mumps_scaling"] == 0
    assert ocp.solve(tolerance=1e-4, ipopt_options={"ipopt.mumps_scaling": 77},
                     max_refinements=0).mesh_refinement["mumps_scaling"] == 77
    assert not {"complementarity_tolerance", "mumps_scaling"} & set(ocp.solve(tolerance=1e-3, max_refinements=0).mesh_refinement)


def test_a_refinement_not_met_returns_its_lowest_estimate_and_says_so(monkeypatch):
    """The saturating push of the test above at 1e-6 with a user's own complementarity (IPOPT's 1e-4: the corners
    rounded) and objective scale (1), its arcs not imposed (since session 35 they hold, and 1e-6 is met after one
    refinement, exact), stopped after 3 refinements (without the arcs it meets 1e-6 after 5: states' true error 2.0e-7
    against the estimate 3.5e-7), so "not met": the solution returned is the one whose largest gated estimate was the
    lowest of the history (unless the last's is within RANKED of it: then the last, on the finer mesh), the record
    describes its mesh and estimate (the last mesh's findings kept apart) and the message says which refinement it is;
    by hand (lowest_estimate), a met refinement, one whose last solution is its best, or one whose best is lower by
    less than RANKED (a sixth newcomer's 0.171 against 0.173: another local optimum was returned), returns the last."""
    import casadi as ca

    import ocp_constraints as oc
    import ocp_constraints.ocp.mesh_refinement as refinement
    from ocp_constraints.ocp.mesh_progress import RANKED, lowest_estimate

    monkeypatch.setattr(refinement, "align_junctions", lambda *args, **kwargs: None)
    model = oc.Model("block", gravity=(0.0, -9.81, 0.0))
    block = model.add_body("block", 2.0, np.diag([0.1, 0.2, 0.3]), rotation="321")
    oc.joints.prismatic(model, "rail", block.com, axis=(1.0, 0.0, 0.0))
    model.add_force("push", block.com, ca.vertcat(model.add_input("F"), 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=1.0)
    ocp.initial({"block.x": 0.0, "block.vbar_x": 0.0})
    ocp.final({"block.x": 1.0, "block.vbar_x": 0.0})
    ocp.bound("F", -10.0, 10.0)
    ocp.minimize_effort(["F"])
    sol = ocp.solve(tolerance=1e-6, ipopt_options={"ipopt.compl_inf_tol": 1e-4, "ipopt.obj_scaling_factor": 1.0},
                    max_refinements=3)
    mr = sol.mesh_refinement
    assert not mr["met"] and {h["objective_scale"] for h in mr["history"]} == {1.0}     # the user's scale kept
    largest = [max(h["estimate"][q] for q in ("states", "multipliers")) for h in mr["history"] if "estimate" in h]
    k = mr.get("returned_refinement", mr["refinements"])
    returned = min(largest) if RANKED * min(largest) < largest[-1] else largest[-1]
    assert max(mr["estimate"][q] for q in ("states", "multipliers")) == returned
    # The multipliers' estimate is relative to the returned solution's load scale, given beside it (a seventh newcomer
    # read history[-1]["load_scale"], absent where the last refinement failed).
    assert mr["load_scale"] == mr["history"][mr.get("returned_refinement", mr["refinements"])]["load_scale"] > 0
    # ... which is the largest load (t > 0) of a companion of the returned solution: the block's own, to its error
    largest = max(float(np.abs(np.asarray(sol.sample(n))[1:]).max()) for n in names(sol)["multipliers"])
    assert mr["load_scale"] == pytest.approx(largest, rel=1e-3)
    assert mr["history"][k]["mesh"] == mr["mesh"] and sol.transcription.scheme.intervals == len(mr["degrees"])
    if k != mr["refinements"]:
        assert f"returned: the solution of refinement {k}" in mr["message"]

    last, earlier = object(), object()
    described = {"refinements": 5, "mesh": [0.0, 0.5, 1.0], "degrees": [7, 7],
                 "estimate": {"states": 1.7e-6, "multipliers": 3.5e-4}, "worst": {"states": "x"}}
    record = {"met": True, "message": "", "estimate": {"states": 1.2e-6, "multipliers": 9e-5}}
    assert lowest_estimate(record, last, 1.4e-3, (3.5e-4, earlier, described, None, ()), 1e-4) is last
    record["met"] = False
    assert lowest_estimate(record, last, 1e-4, (3.5e-4, earlier, described, None, ()), 1e-4) is last
    assert lowest_estimate(record, last, 1.4e-3, (1.4e-3, last, described, None, ()), 1e-4) is last
    assert lowest_estimate(record, last, 0.173, (0.171, earlier, described, None, ()), 1e-4) is last


def test_each_history_entry_gives_its_meshs_objective_as_a_solve_of_that_mesh_alone_finds_it():
    """A sixth newcomer could not tell from the record that two meshes had landed on different optima: each entry
    now carries its solution's objective; the first mesh's against a cold solve of the same mesh."""
    _, problem = build_task("pendulum", "swing_up")
    mr = problem.solve(tolerance=1e-4).mesh_refinement
    _, alone = build_task("pendulum", "swing_up")
    first = alone.solve(Radau(mesh=tuple(mr["history"][0]["mesh"]), degree=5))
    assert all(isinstance(h["objective"], float) for h in mr["history"])
    assert mr["history"][0]["objective"] == pytest.approx(first.objective, rel=1e-8)
