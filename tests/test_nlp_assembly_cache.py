"""Element functions (transcription_elements) and their derivatives (nlp_assembly.derivative_cache) kept per
problem: reused across meshes, and never stale after the problem is edited.

The cached derivatives are checked against CasADi's own AD of the whole NLP graph (an independent
derivation, as in test_nlp_assembly), on a mesh whose element kinds were all differentiated for another
mesh; an edit after a solve is checked against the same edit on a problem that never solved.
"""
import numpy as np
import pytest

from ocp_constraints.ocp.joint_transcription import JointTranscription
from ocp_constraints.ocp.nlp_assembly import derivative_cache
from ocp_constraints.ocp.schemes import Radau
from ocp_constraints.ocp.transcription import Transcription
from ocp_constraints.scenes.registry import build_task

from test_nlp_assembly import _assert_derivatives_agree


@pytest.mark.parametrize("kind", [Transcription, JointTranscription])
def test_a_second_mesh_reuses_every_kind_and_its_derivatives_match_whole_graph_ad(kind):
    problem = build_task("pendulum", "swing_up")[1]
    kind(problem, Radau(mesh=(0.0, 0.5, 1.0), degrees=(3, 6)))
    cache, built = derivative_cache(problem), problem.__dict__["_element_kinds"]
    kinds, functions = len(cache), dict(built)
    # Other mesh points and instance counts, the same degrees (the first interval's too: Radau's input at t0
    # extrapolates it): no new kind, every derivative from the cache.
    tr = kind(problem, Radau(mesh=(0.0, 0.3, 0.6, 1.0), degrees=(3, 6, 3)))
    assert len(cache) == kinds and set(built) == set(functions)        # neither an element function nor a derivative built
    stored = {id(f) for f in functions.values()}
    assert all(id(el.function) in stored for el in tr.block.elements)
    x = tr.initial_guess()
    _assert_derivatives_agree(tr.block, x + 0.1 * np.random.default_rng(3).standard_normal(x.size))


def _swing_up(edit=None, coordinates="maximal"):
    problem = build_task("pendulum", "swing_up")[1]
    problem.coordinates = coordinates
    if edit:
        edit(problem)
    return problem


@pytest.mark.parametrize("edit, coordinates", [
    (lambda p: setattr(p.integral_terms[0], "weight", 3.0 * p.integral_terms[0].weight), "maximal"),
    (lambda p: p.subject_to(p.quantity("motor"), -3.0, 3.0, label="torque"), "maximal"),   # unbounded: -3.0 to 3.8 N m
    (lambda p: p.minimize_integral(p.quantity("rod.psi_dot") ** 2, weight=0.5, label="rate"), "joint"),
], ids=["weight", "path constraint", "objective term, joint coordinates"])
def test_an_edit_after_a_solve_takes_effect(edit, coordinates):
    """A problem solved, edited, solved again gives what the edited problem gives when it never solved."""
    scheme = Radau(6, degree=3)
    problem = _swing_up(coordinates=coordinates)
    before = problem.solve(scheme)
    edit(problem)
    after = problem.solve(scheme, warm_start=before)
    fresh = _swing_up(edit, coordinates).solve(scheme)
    assert abs(after.objective - before.objective) > 1e-3 * abs(before.objective)
    assert after.objective == pytest.approx(fresh.objective, rel=1e-8)
    assert np.abs(after.sample("motor") - fresh.sample("motor")).max() <= 1e-6


@pytest.mark.parametrize("coordinates, start, tolerance", [("maximal", None, 1e-1), ("joint", None, 1e-2)])
def test_an_edit_between_two_refined_solves_takes_effect(coordinates, start, tolerance):
    """A refinement's meshes after the first (its pilot, companions, next meshes) take the first mesh's point
    functions (mesh_refinement._build, ``like=``); an edit between two refined solves must reach every mesh
    of the second: it gives what the edited problem gives when it never solved (the same meshes, the same
    optimum). The maximal form on a short refinement (its NLP is 6x the joint one's)."""
    def weight(p):
        p.integral_terms[0].weight *= 3.0

    problem = _swing_up(coordinates=coordinates)
    before = problem.solve(start, tolerance=tolerance)
    weight(problem)
    after = problem.solve(start, tolerance=tolerance)
    fresh = _swing_up(weight, coordinates).solve(start, tolerance=tolerance)
    assert len(after.mesh_refinement["history"]) == len(fresh.mesh_refinement["history"])
    assert abs(after.objective - before.objective) > 1e-3 * abs(before.objective)
    assert after.mesh_refinement["degrees"] == fresh.mesh_refinement["degrees"]
    assert after.objective == pytest.approx(fresh.objective, rel=1e-8)
    assert np.abs(after.sample("motor") - fresh.sample("motor")).max() <= 1e-6
