"""Solutions against the bench's independent references (ocp_constraints/bench/references.py).

- the pendulum swing-up: the Pontryagin extremal solved by shooting (1 degree of freedom,
  ``J_A psi'' = tau - c sin psi``, DOP853 at rtol 1e-13) and hinge loads by a hand-written
  Newton-Euler balance of the rod: no collocation and no library code;
- the tilted pendulum released from rest: the hand 1-DOF balance integrated by DOP853, its
  hinge force and both constraint moments by ``M = dH_A/dt - r x m g``;
- the sliding cylinder: the exact motion (uniform sliding and spin) and eq. (18).

These also check the references themselves (the bench measures every error against them).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.bench.references import pendulum_reference, sliding_cylinder_reference, swing_up_reference

DEGREE = 6


@pytest.fixture(scope="module")
def reference():
    return swing_up_reference()


def _radau6(coordinates: str) -> dict:
    """Radau degree 6 on 10 and 20 intervals (61 and 121 collocation times)."""
    out = {}
    for n in (10, 20):
        _, ocp = oc.build_task("pendulum", "swing_up")
        ocp.coordinates = coordinates
        out[n] = ocp.solve(oc.Radau(n, degree=DEGREE))
        assert out[n].success, out[n].status
    return out


@pytest.fixture(scope="module")
def radau6():
    """The maximal form: every body coordinate, the hinge's multipliers as NLP variables."""
    return _radau6("maximal")


@pytest.fixture(scope="module")
def radau6_joint():
    """Joint coordinates (the default for this model): the hinge's multipliers from each point's balance."""
    return _radau6("joint")


def _multiplier_errors(sol, ref) -> dict[str, float]:
    """Max |lambda - lambda_ref| (N) per hinge constraint over every collocation time, t = 0 included."""
    return {k: float(np.abs(sol.sample(k) - v).max()) for k, v in ref.multipliers(sol.t).items()}


def test_swing_up_objective_matches_the_pontryagin_optimum(radau6, reference):
    # Radau collocation with d points per interval is superconvergent in the objective, error
    # O(h^(2d-1)) = O(h^11) here. Measured: 4.4e-7 at N = 10, 3.0e-10 at N = 20 (ratio 1450, i.e.
    # order 10.5). The N = 20 bound, 1e-8 (1.1e-9 of J), is 30 times that error and still 40
    # times below the N = 10 one, so a solve that stopped at the coarse accuracy would fail; IPOPT
    # runs at tol 1e-10, well below it.
    assert reference.objective == pytest.approx(8.913005, abs=1e-6)  # the README's optimum
    assert abs(radau6[10].objective - reference.objective) <= 2e-6
    assert abs(radau6[20].objective - reference.objective) <= 1e-8


def test_swing_up_hinge_multipliers_converge_to_the_pontryagin_reference(radau6, reference):
    # The hinge multipliers are algebraic variables of an index-2 DAE: at Radau collocation
    # points they converge at about order d (README, convergence table), not 2d - 1, and their
    # error alternates in sign within each interval, largest at the interval ends near
    # t = 1 s where the rod is fastest. Measured max errors (over v1, v2, every point incl.
    # t = 0): 9.2e-3 N at N = 10, 1.7e-4 N at N = 20, on loads up to 25 N.
    # Bounds: 3 times the order-d prediction from N = 10 (9.2e-3 / 2^6 * 3 = 4.3e-4 N, i.e.
    # 2e-5 of the largest load), and halving h must divide the error by at least 2^(d-1):
    # a wrong multiplier (a missing term, a wrong sign or point) would not shrink with h.
    t = np.linspace(0.0, reference.T, 201)
    scale = max(float(np.abs(v).max()) for v in reference.multipliers(t).values())
    assert scale == pytest.approx(25.15, abs=0.01)
    coarse, fine = _multiplier_errors(radau6[10], reference), _multiplier_errors(radau6[20], reference)
    for k in ("hinge.v1.lambda", "hinge.v2.lambda"):
        assert fine[k] <= 2e-5 * scale, (k, fine[k])
        assert coarse[k] / fine[k] >= 2 ** (DEGREE - 1), (k, coarse[k], fine[k])
    # A rod in its swing plane: no force along the hinge axis, no constraint moments (exactly).
    for k in ("hinge.v3.lambda", "hinge.w1.lambda", "hinge.w2.lambda"):
        assert fine[k] <= 1e-12 * scale, (k, fine[k])
    # The optimal torque -p_2 / (2 J_A) and the state follow the extremal to the same accuracy.
    sol = radau6[20]
    psi, psi_dot = reference.states(sol.t)
    assert np.abs(sol.sample("rod.psi") - psi).max() <= 1e-7
    assert np.abs(sol.sample("rod.psi_dot") - psi_dot).max() <= 1e-6
    assert np.abs(sol.sample("motor") - reference.torque(sol.t)).max() <= 1e-4 * reference.max_torque


def test_tilted_pendulum_motion_and_hinge_loads_match_the_hand_reference():
    # The states come from an independent 1-DOF integration here (test_pendulum_hinge.py
    # evaluates the hand balance on the library's own states).
    scene = oc.build_scene("pendulum")
    traj = oc.simulate_scene(scene, 3.0)
    p = scene.model.parameters
    ref = pendulum_reference(p, traj.t)
    # CVODES at rtol = atol = 1e-12 against DOP853 at 1e-13, 3 s (about 1.5 swings): measured
    # 1.1e-10 rad and 6.7e-10 rad/s; bound 1e-9 of each state's range (4e-9 rad/s for psi_dot)
    for k, v in ref["states"].items():
        assert np.abs(traj.sample(k) - v).max() <= 1e-9 * max(1.0, float(np.abs(v).max())), k
    m, L, g = p["mass"], p["length"], p["gravity"]
    for k, v in ref["lambda"].items():
        scale = m * g * (L if ".w" in k else 1.0)      # forces in N, moments in N m
        assert np.abs(traj.sample(k) - v).max() <= 1e-8 * scale, k
    # the constraint moments are really there (the rod is tilted 30 deg out of its plane)
    assert np.abs(ref["lambda"]["hinge.w1.lambda"]).max() > 0.1 * m * g * L


def test_sliding_cylinder_follows_the_exact_motion_and_eq18():
    scene = oc.build_scene("sliding_cylinder")
    traj = oc.simulate_scene(scene, 3.0)
    p = scene.model.parameters
    ref = sliding_cylinder_reference(p, traj.t)
    for k, v in ref["states"].items():
        # positions grow linearly (|x| up to ~p x_dot0 t), angles by psi' t and phi' t
        assert np.abs(traj.sample(k) - v).max() <= 1e-9 * max(1.0, float(np.abs(v).max())), k
    m, g = p["mass"], p["gravity"]
    assert np.abs(traj.sample("plane.normal.lambda") - ref["lambda"]["plane.normal.lambda"]).max() <= 1e-9 * m * g
    tilt = ref["lambda"]["plane.tilt.lambda"]
    assert abs(tilt[0]) > 1e-3                        # eq. (18)'s moment is not zero here
    assert np.abs(traj.sample("plane.tilt.lambda") - tilt).max() <= 1e-8 * abs(tilt[0])
    assert math.isclose(traj.t[-1], 3.0)


def test_joint_coordinates_match_the_pontryagin_reference_closer_than_the_maximal_form(radau6, radau6_joint, reference):
    # In joint coordinates the hinge's multipliers are not NLP variables of an index-2 DAE but
    # follow from each point's balance (paper sec. 5, Phi = lambda A) with the collocated
    # acceleration, so they converge with the motion itself. Measured max errors: 1.7e-5 N at
    # N = 10 and 1.0e-6 N at N = 20 (maximal form: 9.2e-3 and 1.7e-4 N).
    for n in (10, 20):
        assert abs(radau6_joint[n].objective - reference.objective) <= abs(radau6[n].objective - reference.objective) + 1e-9
    coarse = _multiplier_errors(radau6_joint[10], reference)
    fine = _multiplier_errors(radau6_joint[20], reference)
    maximal = _multiplier_errors(radau6[20], reference)
    t = np.linspace(0.0, reference.T, 201)
    scale = max(float(np.abs(v).max()) for v in reference.multipliers(t).values())
    for k in ("hinge.v1.lambda", "hinge.v2.lambda"):
        assert fine[k] <= 1e-7 * scale, (k, fine[k])            # 2.5e-6 N: 2.5x the measured error
        assert fine[k] < maximal[k] / 10, (k, fine[k], maximal[k])
        assert coarse[k] / fine[k] >= 2 ** 3, (k, coarse[k], fine[k])   # shrinks with h, faster than h^3
    for k in ("hinge.v3.lambda", "hinge.w1.lambda", "hinge.w2.lambda"):
        assert fine[k] <= 1e-12 * scale, (k, fine[k])
