"""The user-problem OCP suite of ``ocp-constraints bench --ocp-suite`` (issue 13 item 6).

Each minimal-coordinate model (:mod:`ocp_constraints.bench.ocp_suite_minimal`, derived by hand
from energies) is checked against the library's maximal model of the same problem: at a random
consistent state and random inputs, the library's accelerations (KKT system, eqs. 25-26), mapped
into the minimal coordinates, must solve the minimal model's equations, and the loads the
problems bound (a four-bar's pin force, the walker's and the disk's contact forces) must be the
library's constraint loads. Two derivations that share only the numbers. Then one problem of
the suite end to end through the CLI on a coarse mesh (skipped without rockit).
"""
from __future__ import annotations

import csv
import math

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.bench import ocp_suite as planar
from ocp_constraints.bench import ocp_suite_3d as spatial
from ocp_constraints.bench import ocp_suite_minimal as minimal
from ocp_constraints.bench import ocp_suite_minimal_3d as minimal3d
from ocp_constraints.bench.peers import available
from ocp_constraints.mechanics.state import project_positions, project_speeds


def _maximal_motion(ocp, start: dict[str, float], inputs: np.ndarray, seed: int):
    """A consistent state near ``start`` (named coordinates), random speeds, and the library's
    ``q, q', q''`` and multipliers there under ``inputs``."""
    e = ocp.eqs
    names = ocp.model.coordinate_names
    q = np.zeros(e.nq)
    for k, n in enumerate(names):
        q[k] = start.get(n, 1.0 if n.endswith(".qw") else 0.0)
    q = project_positions(e, q, 0.0)
    u = project_speeds(e, q, np.random.default_rng(seed).normal(size=e.nu), 0.0)
    udot, lam = (np.asarray(v, float).ravel() for v in e.forward_dynamics(q, u, 0.0, inputs, np.zeros(len(inputs))))
    N = lambda x: np.asarray(e.rate_matrix(x), float)
    qd = N(q) @ u
    h = 1e-6      # d N(q(t))/dt u by a central difference along q': truncation ~1e-12, round-off ~1e-10
    qdd = N(q) @ udot + (N(q + h * qd) - N(q - h * qd)) @ u / (2 * h)
    return q, qd, qdd, lam


def _minimal_accelerations(mp, x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The minimal model's algebraic variables ``z`` (accelerations, then loads) at ``x, w``:
    its equations are affine in ``z``."""
    z0 = ca.DM.zeros(mp.z.numel())
    solve = ca.Function("z", [mp.x, mp.u], [-ca.solve(ca.jacobian(mp.alg, mp.z), ca.substitute(mp.alg, mp.z, z0))])
    return np.asarray(solve(x, w), float).ravel()


def _load(ocp, channel: str, q, qd_speeds, lam) -> np.ndarray:
    e = ocp.eqs
    names = [c.prefix for c in e.load_channels]
    lsym = ca.SX.sym("lam", e.nc)
    F = ca.Function("F", [e.q, lsym], [e.joint_load_expressions(lsym)[names.index(channel)]["F"]])
    return np.asarray(F(q, lam), float).ravel()


def _index(ocp, names):
    return [ocp.model.coordinate_names.index(n) for n in names]


@pytest.mark.parametrize("which", ["acrobot", "cart_double_pendulum", "walker"])
def test_minimal_chain_accelerations_equal_the_maximal_models(which):
    """Chains on hinges: the minimal coordinates are some of the bodies' (lean = -psi for the walker)."""
    rng = np.random.default_rng(7)
    if which == "walker":
        ocp, mp = spatial.walker(), minimal3d.walker()
        coords, sign = [f"{n}.psi" for n in spatial.LINKS], -1.0
        start = {c: v for c, v in zip(coords, [-0.3, 0.2, 0.05, -0.4, 0.1])}
    else:
        ocp = getattr(planar, which)()
        mp = getattr(minimal, which)()
        coords = ["upper.psi", "lower.psi"] if which == "acrobot" else ["cart.x", "rod1.psi", "rod2.psi"]
        sign, start = 1.0, {c: v for c, v in zip(coords, rng.uniform(-2, 2, len(coords)))}
    w = rng.uniform(-5, 5, mp.u.numel())
    q, qd, qdd, lam = _maximal_motion(ocp, start, w, seed=3)
    idx = _index(ocp, coords)
    z = _minimal_accelerations(mp, np.concatenate([sign * q[idx], sign * qd[idx]]), w)
    np.testing.assert_allclose(z[: len(idx)], sign * qdd[idx], rtol=1e-7, atol=1e-7)
    if which == "walker":        # the stance foot's contact force: linear momentum vs the ankle's multipliers
        contact = _walker_contact_force(mp, np.concatenate([sign * q[idx], sign * qd[idx]]), w)
        np.testing.assert_allclose(contact, _load(ocp, "ankle", q, None, lam)[:2], rtol=1e-7, atol=1e-6)


def _walker_contact_force(mp, x, w) -> np.ndarray:
    """The minimal walker's ground force on the stance foot: its first path rows are ``F_y`` and
    ``F_x -/+ mu F_y``, so ``F_x`` is ``row 1 + mu F_y``."""
    from ocp_constraints.bench.ocp_suite_params import WALKER

    z0 = ca.DM.zeros(mp.z.numel())
    zsol = -ca.solve(ca.jacobian(mp.alg, mp.z), ca.substitute(mp.alg, mp.z, z0))
    rows = [ca.substitute(g, mp.z, zsol) for g, _, _ in mp.path[:2]]
    Fy, row = (float(ca.Function("r", [mp.x, mp.u], [r])(x, w)) for r in rows)
    return np.array([row + WALKER["mu"] * Fy, Fy])


def test_minimal_four_bar_accelerations_and_pin_force_equal_the_maximal_models():
    """One degree of freedom (the crank): its acceleration, and the pin force at B (bounded in the
    problem) from Newton-Euler on coupler and rocker vs the library's multipliers of joint B."""
    ocp, mp = planar.four_bar(), minimal.four_bar()
    theta = 0.9
    _, _, _, beta, gamma = (np.asarray(ca.DM(v), float).ravel() for v in minimal.four_bar_geometry(theta))
    start = {"crank.psi": theta, "coupler.psi": float(beta[0]), "rocker.psi": float(gamma[0])}
    w = np.array([1.7])
    q, qd, qdd, lam = _maximal_motion(ocp, start, w, seed=5)
    k = _index(ocp, ["crank.psi"])
    rocker = float(ca.DM(minimal.four_bar_geometry(q[k[0]])[4]))      # the minimal model's assembly branch
    assert q[_index(ocp, ["rocker.psi"])[0]] == pytest.approx(rocker, abs=1e-9)
    z = _minimal_accelerations(mp, np.concatenate([q[k], qd[k]]), w)
    np.testing.assert_allclose(z[0], qdd[k[0]], rtol=1e-7, atol=1e-7)
    F_B_on_coupler = _load(ocp, "B@coupler", q, None, lam)
    np.testing.assert_allclose(z[3:5], F_B_on_coupler[:2], rtol=1e-7, atol=1e-7)


def test_minimal_rolling_disk_angle_accelerations_and_contact_force_equal_the_maximal_models():
    """Maggi's equations in (x, y, 3-1-3 angles) with the angle rates as speeds vs the library's
    rolling contact; the contact force (friction cone of the problem) vs the contact's multipliers."""
    ocp, mp = spatial.rolling_disk(), minimal3d.rolling_disk()
    coords = [f"disk.{c}" for c in ("x", "y", "psi", "theta", "phi")]
    start = dict(zip(coords, [0.1, -0.2, 0.4, 1.3, 0.7]))
    start["disk.z"] = 0.2 * math.sin(1.3)
    w = np.array([0.05, -0.03, 0.02])
    q, qd, qdd, lam = _maximal_motion(ocp, start, w, seed=11)
    idx = _index(ocp, coords)
    z = _minimal_accelerations(mp, np.concatenate([q[idx], qd[idx][2:]]), w)
    np.testing.assert_allclose(z, qdd[idx][2:], rtol=1e-7, atol=1e-7)
    # the contact force of the minimal model, as its path rows give it: F_z and |F_xy|^2 - mu^2 F_z^2
    z0 = ca.DM.zeros(mp.z.numel())
    zsol = -ca.solve(ca.jacobian(mp.alg, mp.z), ca.substitute(mp.alg, mp.z, z0))
    Fz, cone = (float(ca.Function("r", [mp.x, mp.u], [ca.substitute(g, mp.z, zsol)])(
        np.concatenate([q[idx], qd[idx][2:]]), w)) for g, _, _ in mp.path)
    F = _load(ocp, "contact", q, None, lam)
    assert F[2] == pytest.approx(Fz, rel=1e-7)
    assert F[0] ** 2 + F[1] ** 2 - 0.2**2 * F[2] ** 2 == pytest.approx(cone, rel=1e-6, abs=1e-9)


def _quad_minimal_coordinates(ocp, q: np.ndarray) -> np.ndarray:
    """Quadrotor position, 3-2-1 angles (yaw, pitch, roll) of its quaternion, and the load's angles
    ``a = asin(r_y / |r|)``, ``b = atan2(-r_x, -r_z)`` of the rod ``r`` from the hook."""
    from ocp_constraints.bench.ocp_suite_params import QUAD

    v = dict(zip(ocp.model.coordinate_names, q))
    qw, qx, qy, qz = (v[f"quad.{c}"] for c in ("qw", "qx", "qy", "qz"))
    n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    qw, qx, qy, qz = qw / n, qx / n, qy / n, qz / n
    R = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)],
                  [2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)],
                  [2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)]])
    x = np.array([v["quad.x"], v["quad.y"], v["quad.z"]])
    r = np.array([v["ball.x"], v["ball.y"], v["ball.z"]]) - (x + R @ np.array([0, 0, -QUAD["hook"]]))
    r = r / np.linalg.norm(r)
    return np.concatenate([x, [math.atan2(R[1, 0], R[0, 0]), -math.asin(R[2, 0]), math.atan2(R[2, 1], R[2, 2]),
                               math.asin(r[1]), math.atan2(-r[0], -r[2])]])


def test_minimal_quadrotor_accelerations_equal_the_maximal_models():
    """Eight minimal coordinates (position, yaw-pitch-roll, two load angles) as functions of the
    library's quaternion and ball position, differentiated along the library's motion."""
    ocp, mp = spatial.quadrotor_load(), minimal3d.quadrotor_load()
    c, s = math.cos(0.15), math.sin(0.15)
    start = {"quad.x": 0.3, "quad.y": -0.1, "quad.z": 0.2, "quad.qw": c, "quad.qx": s * 0.6, "quad.qy": s * 0.8,
             "ball.x": 0.45, "ball.y": 0.1, "ball.z": -0.3}
    w = np.array([3.0, 2.5, 2.0, 3.5])
    q, qd, qdd, _ = _maximal_motion(ocp, start, w, seed=13)
    path = lambda tau: _quad_minimal_coordinates(ocp, q + tau * qd + tau**2 / 2 * qdd)
    h = 1e-4
    m0, mp_, mm = path(0.0), path(h), path(-h)
    rate, accel = (mp_ - mm) / (2 * h), (mp_ - 2 * m0 + mm) / h**2
    z = _minimal_accelerations(mp, np.concatenate([m0, rate]), w)
    np.testing.assert_allclose(z, accel, rtol=1e-5, atol=1e-5)


def test_suite_accuracy_summary_finds_the_converged_reference_and_where_ours_stays_within_1e_6():
    """The chain's summary on made-up objectives with a known answer: the reference converging
    geometrically (changes 1e-3, 1e-5, 1e-7 relative to 1), ours off by 1e-3, 4e-7, 2e-7, 0."""
    from ocp_constraints.bench.ocp_suite_convergence import summarize

    refs = [1 + 1e-3 + 1e-5 + 1e-7, 1 + 1e-5 + 1e-7, 1 + 1e-7, 1.0]
    ours = [1 + 1e-3, 1 + 4e-7, 1 - 2e-7, 1.0]
    steps = [{"mesh": f"Radau7 N={n}", "N": n, "ours_success": True, "ours_objective": o, "ours_s": 1.0, "ours_cpu_s": 1.0,
              "ref_success": True, "ref_objective": r, "ref_s": 1.0, "ref_cpu_s": 1.0}
             for n, o, r in zip((20, 40, 80, 160), ours, refs)]
    out = summarize(steps)
    assert out["reference_objective"] == 1.0
    assert out["reference_change"] == pytest.approx(1e-7, rel=1e-6)
    assert out["reference_ratio"] == pytest.approx(1e-2, rel=1e-4)
    assert out["reference_tail"] == pytest.approx(1e-7 * 1e-2 / (1 - 1e-2), rel=1e-4)
    assert out["within_target_from"] == "Radau7 N=40"          # 4e-7 and 2e-7 <= 1e-6; 1e-3 is not
    assert [s["deviation"] for s in steps[:3]] == pytest.approx([1e-3, 4e-7, 2e-7], rel=1e-6)
    assert out["agreement"] == pytest.approx(2e-7, rel=1e-6)


@pytest.mark.skipif(not available("rockit"), reason="rockit is not installed (pip install rockit-meco)")
def test_ocp_suite_cli_writes_one_problem_whose_optimum_equals_the_minimal_formulations_on_every_mesh(tmp_path):
    """``bench --ocp-suite --only cart_double_pendulum`` on coarse meshes (timed: Radau 3, N = 8;
    accuracy chain: Radau 3, N = 6, 12, 24): ours and rockit succeed from the user-level guess, and
    on every mesh of the chain our optimum (joint coordinates, from the library's model) equals the
    hand-derived minimal-coordinate collocation's: the same discrete problem derived twice."""
    from ocp_constraints.cli import main

    code = main(["bench", "--ocp-suite", "--only", "cart_double_pendulum", "--runs", "1", "--ocp-n", "8",
                 "--ocp-fine", "6", "3", "--ocp-coordinates", "maximal", "--out", str(tmp_path)])
    assert code == 0
    row = next(csv.DictReader((tmp_path / "ocp_suite.csv").open()))
    assert row["problem"] == "cart_double_pendulum"
    for who in ("ours", "rockit", "fine", "reference"):
        assert row[f"{who}_success"] == "True", (who, row)
    steps = list(csv.DictReader((tmp_path / "ocp_suite.chain.csv").open()))
    assert [s["mesh"] for s in steps] == ["Radau3 N=6", "Radau3 N=12", "Radau3 N=24"]
    for s in steps:
        assert float(s["equal_mesh"]) <= 1e-7, s
    assert float(row["reference_objective"]) == float(steps[-1]["ref_objective"])
    assert "| cart_double_pendulum | Radau3 N=12 |" in (tmp_path / "ocp_suite.md").read_text()
