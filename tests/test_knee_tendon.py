"""Hill muscles with compliant tendons (issue 15, C20): the curves against closed forms and the paper's constants,
the equilibrium against a second derivation (fibre length as the unknown), the rigid-tendon limit against
:mod:`ocp_constraints.biomech.knee_hill`, and the NLP's fast-activation, short-tendon limit against the rigid Hill
static optimisation on a small synthetic problem. No trial data."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.biomech import knee_hill
from ocp_constraints.biomech.knee_passive import less_fibre_passive, less_joint_passive
from ocp_constraints.biomech.knee_static import RESERVED, solve_static
from ocp_constraints.biomech.knee_tendon import solve_tendon, tendon_defects
from ocp_constraints.biomech.knee_tendon_curves import (C1, C2, C3, SMOOTH, active_force_length, equilibrium_residual,
                                                        force_velocity, passive_force_length, static_tendon_force,
                                                        tendon_compliance, tendon_force, tendon_length,
                                                        tendon_stiffness)
from ocp_constraints.errors import KneeError


def test_tendon_force_is_F0_at_the_strain_at_one_norm_force():
    assert tendon_force(1.049) == pytest.approx(1.0, abs=1e-12)
    assert tendon_force(1.10, strain=0.10) == pytest.approx(1.0, abs=1e-12)


def test_tendon_stiffness_is_the_papers_35_at_its_own_strain():
    # the paper's printed kT = 35 with c1, c2, c3 gives F~T = 1 at l~T = c2 + ln((1 + c3)/c1)/35
    strain_35 = C2 + math.log((1 + C3) / C1) / 35.0 - 1.0
    assert tendon_stiffness(strain_35) == pytest.approx(35.0, rel=1e-12)
    assert strain_35 == pytest.approx(0.04736, abs=1e-5)


def test_tendon_force_is_zero_where_the_exponential_equals_c3_over_c1():
    l0 = C2 + math.log(C3 / C1) / tendon_stiffness()
    assert tendon_force(l0) == pytest.approx(0.0, abs=1e-15)
    assert abs(l0 - 1.0) < 2e-3          # about the slack length


def test_tendon_length_inverts_the_tendon_curve_and_its_slope():
    F = np.linspace(0.0, 4.0, 41)
    assert np.allclose(tendon_force(tendon_length(F)), F, atol=1e-12)
    dF, Fi = 1e-6, F[1:]
    numeric = (tendon_length(Fi + dF) - tendon_length(Fi - dF)) / (2 * dF)      # central differences
    assert np.allclose(tendon_compliance(Fi), numeric, rtol=1e-6)


def test_fibre_curves_at_optimal_length_and_zero_speed():
    # the paper's curves are fits: f_L(1) and f_V(0) are 1 to their printed digits
    assert active_force_length(1.0) == pytest.approx(1.0, abs=1e-3)
    assert force_velocity(0.0) == pytest.approx(1.0, abs=3e-3)
    # f_PE = (exp(kPE (l - 1)/e0) - 1)/(exp(kPE) - 1) is exactly 1 at l = 1 + e0 (kPE = 4, e0 = 0.6)
    assert passive_force_length(1.6) == pytest.approx(1.0, abs=1e-8)
    assert passive_force_length(0.7) == pytest.approx(0.0, abs=SMOOTH)


def test_fibre_curves_match_the_rigid_hill_module_and_work_on_casadi_symbols():
    """The active and force-velocity curves are the rigid Hill module's own (one implementation): on arrays they
    equal their CasADi evaluation point by point; the passive curve is its smooth version."""
    l = np.linspace(0.4, 1.7, 27)
    v = np.linspace(-1.0, 1.0, 27)
    y = ca.SX.sym("y")
    curves = ca.Function("curves", [y], [ca.vertcat(knee_hill.active_force_length(y), knee_hill.force_velocity(y))])
    assert np.allclose(active_force_length(l), [float(curves(x)[0]) for x in l], rtol=1e-13, atol=1e-15)
    assert np.allclose(force_velocity(v), [float(curves(x)[1]) for x in v], rtol=1e-13, atol=1e-15)
    assert np.allclose(passive_force_length(l), knee_hill.passive_force_length(l), atol=SMOOTH / 2)
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [ca.vertcat(active_force_length(x), force_velocity(x - 1.0), passive_force_length(x),
                                          tendon_force(x), tendon_length(x))])
    for xi in (0.8, 1.0, 1.05, 1.3):
        ref = [active_force_length(xi), force_velocity(xi - 1.0), passive_force_length(xi), tendon_force(xi),
               tendon_length(xi)]
        assert np.allclose(np.asarray(f(xi)).ravel(), ref, rtol=1e-13, atol=1e-15)


def _bisect(g, lo, hi, n=200):
    for _ in range(n):
        mid = 0.5 * (lo + hi)
        if np.sign(g(mid)) == np.sign(g(lo)):
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("a, L_mt, alpha0", [(0.0, 0.34, 0.2), (0.3, 0.33, 0.2), (0.8, 0.345, 0.4), (1.0, 0.32, 0.0)])
def test_equilibrium_tendon_force_equals_the_fibre_length_formulation(a, L_mt, alpha0):
    """Second derivation: the fibre length as the unknown (the other formulation of De Groote et al. 2016):
    tendon length ``L_mt - l_M cos(alpha)``, its force from the tendon curve, equal to the fibre's force along it."""
    l_opt, l_s, V = 0.06, 0.25, 0.0
    h = l_opt * math.sin(alpha0)

    def g(lM):
        cos_a = math.sqrt(lM * lM - h * h) / lM
        FT = float(tendon_force((L_mt - lM * cos_a) / l_s))
        l = lM / l_opt
        return FT - (a * active_force_length(l) * force_velocity(0.0) + float(passive_force_length(l))) * cos_a

    lM = _bisect(g, max(h * 1.0001, 0.3 * l_opt), 1.9 * l_opt)
    cos_a = math.sqrt(lM * lM - h * h) / lM
    expected = float(tendon_force((L_mt - lM * cos_a) / l_s))
    FT = float(static_tendon_force(a, L_mt, V, l_opt, l_s, alpha0))
    assert FT == pytest.approx(expected, abs=1e-9)
    assert abs(float(equilibrium_residual(a, FT, 0.0, L_mt, V, l_opt, l_s, alpha0))) < 1e-9


def test_short_tendon_gives_the_rigid_hill_forces():
    """``l_s << l_opt``: the tendon's stretch (at most 5 % of l_s) is negligible, so F0 F~T = a F_active + F_passive
    of the rigid-tendon model (:func:`knee_hill.hill_forces`), at rest and at speed."""
    rng = np.random.default_rng(3)
    n = 12
    F0, l_opt, l_s = rng.uniform(300, 2000, n), rng.uniform(0.04, 0.2, n), 1e-5
    alpha0 = rng.uniform(0.0, 0.4, n)
    L = l_opt * np.cos(alpha0) * rng.uniform(0.7, 1.4, n) + l_s
    V = rng.uniform(-0.3, 0.3, n)
    a = rng.uniform(0.0, 1.0, n)
    rigid = knee_hill.hill_forces(L[None], V[None], F0, l_opt, l_s, alpha0)
    expected = (a * rigid.active + rigid.passive).ravel()
    FT = static_tendon_force(a, L, V, l_opt, l_s, alpha0)
    assert np.allclose(FT * F0, expected, atol=2e-3 * F0)


def _synthetic(N=6, nm=3, seed=0):
    """A small problem of the knee's shape (rows: RESERVED + 5 locked directions) built from a known state."""
    rng = np.random.default_rng(seed)
    nr = len(RESERVED) + 5
    t = np.linspace(0.0, 0.05 * (N - 1), N)
    F0 = np.array([800.0, 1200.0, 500.0])[:nm]
    l_opt = np.array([0.08, 0.06, 0.1])[:nm]
    alpha0 = np.array([0.1, 0.3, 0.0])[:nm]
    l_s = 1e-5 * np.ones(nm)
    ramp = 1.0 + 0.15 * np.sin(2 * np.pi * t / t[-1])[:, None] * np.array([1.0, -0.8, 0.5])[:nm]
    L = l_opt * np.cos(alpha0) * ramp + l_s
    V = np.gradient(L, t, axis=0)
    R = rng.normal(0.0, 0.03, (N, nr, nm))
    A = rng.normal(0.0, 1.0, (N, 5, nr))
    a_true = 0.2 + 0.1 * rng.random((N, nm))
    hill = knee_hill.hill_forces(L, V, F0, l_opt, l_s, alpha0)
    lam = rng.normal(0.0, 200.0, (N, 5))
    Q = np.einsum("ncm,nm->nc", R, a_true * hill.active + hill.passive) + np.einsum("njc,nj->nc", A, lam)
    return t, Q, R, A, F0, L, V, l_opt, l_s, alpha0, hill


def test_fast_activation_short_tendon_limit_is_the_rigid_hill_static_optimisation():
    t, Q, R, A, F0, L, V, l_opt, l_s, alpha0, hill = _synthetic()
    M = {"hip_flexion": 5.0 + 0 * t, "knee_flexion": -3.0 + 0 * t}        # passive moments on two rows
    rows = [RESERVED.index(c) for c in M]
    Qc = less_joint_passive(Q, M)                                       # the C20 right-hand side: Q - M
    joint, _ = less_fibre_passive(M, R, hill.passive)                   # rigid Hill: fibres' share counted once
    ref = solve_static(t, less_joint_passive(Q, joint), R, A, hill.active, contact_nonnegative=False,
                       passive=hill.passive)
    res = solve_tendon(t, Qc, R, A, F0, L, V, l_opt, l_s, alpha0, passive_rows=rows, contact_nonnegative=False,
                       tau_act=1e-5, tau_deact=1e-5)
    assert res.success and res.equilibrium_residual < 1e-8 and res.residual < 1e-6
    assert np.abs(tendon_defects(t, res.tendon_force, res.tendon_rate)).max() < 1e-8
    assert np.allclose(res.activation, ref.activation, atol=2e-3)
    assert np.allclose(res.force, ref.force, atol=2e-3 * F0.max())
    assert np.allclose(res.lam, ref.lam, atol=1.0)                     # N, loads of hundreds of N
    assert np.allclose(res.excitation, res.activation, atol=2e-3)


def test_compliant_tendon_rejects_a_nonpositive_slack_length():
    t, Q, R, A, F0, L, V, l_opt, l_s, alpha0, _ = _synthetic()
    with pytest.raises(KneeError, match="slack length"):
        solve_tendon(t, Q, R, A, F0, L, V, l_opt, np.zeros(3), alpha0)
