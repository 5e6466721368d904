"""Mesh points whose times are NLP variables (ocp/free_mesh_points.py; issue 19), checked against closed forms."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.errors import ModelError
from ocp_constraints.ocp.imposed_arcs import Arc, pinned_points
from ocp_constraints.ocp.schemes import HermiteSimpson

sys.path.insert(0, str(Path(__file__).parent))
from test_mesh_refinement_switches import T_FINAL, T_SWITCH, _block, _closed_form_state_error  # noqa: E402


def _bang_bang(problem, scheme):
    """The block's transcription with its force held at 2 N, then at -1 N, the jump at the first free point."""
    at = float(scheme.mesh_fractions[scheme.free_points[0]])
    tr = problem.transcription(scheme)
    tr.arcs = (Arc("F", 2.0, 0.0, at), Arc("F", -1.0, at, 1.0))
    return tr


@pytest.mark.parametrize("coordinates", ["auto", "maximal"])
@pytest.mark.parametrize("point", [3, 4, 6])
def test_a_jump_held_on_both_sides_lands_on_the_closed_form_switch_when_its_mesh_point_is_free(coordinates, point):
    # Pontryagin: F = 2 up to t1 = 1/sqrt(3), -1 after, T = sqrt(3). Nominal point 3/10 .. 6/10 of a 2 s horizon:
    # 0.6 .. 1.2 s, against the switch at 0.577 s. Each phase is one bound: collocation is exact there.
    problem = _block()
    problem.coordinates = coordinates
    sol = _bang_bang(problem, oc.Radau(10, degree=3, free_points=(point,))).solve({})
    mesh = sol.transcription.scheme.mesh_fractions
    assert math.isclose(sol.t_final, T_FINAL, abs_tol=1e-9)
    assert math.isclose(mesh[point] * sol.t_final, T_SWITCH, abs_tol=1e-9)
    assert _closed_form_state_error(sol) < 1e-9
    # The solution is read on the solved mesh: its points' times follow it.
    assert np.allclose(sol.t, sol.transcription.fractions * sol.t_final)
    assert np.all(sol.inputs[0, sol.t <= T_SWITCH - 1e-9][1:] == 2.0) and np.all(sol.inputs[0, sol.t > T_SWITCH + 1e-9] == -1.0)


def test_a_jump_between_two_arcs_of_one_input_frees_no_point():
    problem = _block()
    tr = _bang_bang(problem, oc.Radau(10, degree=3, free_points=(4,)))
    fixed, freed = pinned_points(tr, list(tr.arcs))
    assert [len(f) for f in freed] == [0, 0]
    assert len(np.intersect1d(fixed[0], fixed[1])) == 0 and len(fixed[0]) + len(fixed[1]) == tr.layout.n_points - 1


def test_a_warm_start_from_a_solution_on_free_points_reads_it_at_its_solved_times():
    problem = _block()
    first = _bang_bang(problem, oc.Radau(10, degree=3, free_points=(4,))).solve({})
    mesh = first.transcription.scheme.mesh_fractions
    again = oc.Radau(mesh=tuple(mesh), degrees=(5,) * 10, free_points=(4,))
    tr = _bang_bang(problem, again)
    # The start: the first solution's polynomials at this mesh's points (read on the nominal mesh, they would be
    # 0.4 s off the switch there).
    X = tr.layout.split(tr.guess_from(first))[0]
    t = tr.fractions * first.t_final
    x = np.where(t <= T_SWITCH, t**2, T_SWITCH**2 + 2 * T_SWITCH * (t - T_SWITCH) - (t - T_SWITCH) ** 2 / 2)
    assert np.max(np.abs(np.asarray(X)[0] - x)) < 1e-9
    sol = tr.solve({}, warm_start=first)
    assert math.isclose(sol.transcription.scheme.mesh_fractions[4] * sol.t_final, T_SWITCH, abs_tol=1e-9)


@pytest.mark.parametrize("scheme, said", [
    (lambda: HermiteSimpson(10, free_points=(3,)), "Radau"),
    (lambda: oc.Radau(10, degree=3, free_points=(0,)), "1 to 9"),
    (lambda: oc.Radau(10, degree=3, free_points=(10,)), "1 to 9"),
    (lambda: oc.Radau(10, degree=3, free_points=(5, 3)), "increasing"),
])
def test_free_points_off_a_radau_mesh_s_inner_points_are_refused(scheme, said):
    with pytest.raises(ModelError, match=said):
        scheme()


def test_a_model_that_reads_the_time_refuses_free_points():
    problem = _block()
    problem.minimize_integral(1e-3 * (problem.quantity("F") - ca.sin(problem.eqs.t)) ** 2, label="timed")
    with pytest.raises(ModelError, match="reads the time itself in its integrand"):
        problem.solve(oc.Radau(10, degree=3, free_points=(4,)))


def test_casadi_s_warning_on_pinned_values_is_left_out_of_stderr_and_other_lines_pass(capfd):
    """CasADi counts a variable held at lower bound = upper bound as an equality and warns "NLP is overconstrained"
    where those outnumber the variables, though IPOPT solves (fixed variables): where arcs are imposed the warning is
    left out; another line written meanwhile still reaches stderr."""
    from ocp_constraints.ocp.progress import without_pin_warning

    def solve(pinned: bool):
        x = ca.MX.sym("x", 2)          # a new solver each time: CasADi warns once per solver
        solver = ca.nlpsol("s", "ipopt", {"x": x, "f": ca.sumsqr(x - 1), "g": x[0] - x[1]},
                           {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"})
        with without_pin_warning(pinned):
            res = solver(x0=[0.5, 0.5], lbx=[0.5, 0.5], ubx=[0.5, 0.5], lbg=0.0, ubg=0.0)   # 3 equalities, 2 variables
            sys.stderr.write("another line\n")
        assert solver.stats()["success"] and np.allclose(np.asarray(res["x"]).ravel(), [0.5, 0.5])
        return capfd.readouterr().err

    assert "NLP is overconstrained" in solve(False)
    err = solve(True)
    assert "overconstrained" not in err and "another line" in err
