"""The gait trial's vectorised inverse dynamics against independent evaluations, frame by frame.

The run (:mod:`ocp_constraints.biomech.gait_compiled`) evaluates one CasADi function of the
frame over all frames at once: kinematics by AD, the balances solved block-triangularly,
``Phi = J^T G^T lambda + tau``. Here each piece is recomputed at random frames by other
routes: the Newton-Euler balance residual ``M u' - f - f_ext - G^T lambda - B tau`` from
``SystemEquations`` itself, the bodies' velocities and accelerations by finite differences
of the poses along the coordinate splines, and the quintic spline against SciPy's.
"""
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.biomech.gait import run_inverse_dynamics
from ocp_constraints.biomech.gait_compiled import GaitFunctions, quaternions
from ocp_constraints.biomech.gait_signals import QuinticSpline
from ocp_constraints.dynamics.inverse import block_triangular_solve
from ocp_constraints.mechanics.rotations import quaternion_from_rotation

G = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim-gait2354-subject01"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def run(cache):
    import os

    from ocp_constraints.biomech import gait_compiled

    old = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(cache)          # a cold cache: the functions are built here
    gait_compiled._MEMO.clear()
    try:
        r = run_inverse_dynamics(G / "subject01_simbody.osim", G / "subject01_walk1_ik.mot", G / "subject01_walk1_grf.mot",
                                 start=0.5, end=1.1)
    finally:
        if old is None:
            os.environ.pop("XDG_CACHE_HOME")
        else:
            os.environ["XDG_CACHE_HOME"] = old
    return r


def test_vectorised_solution_satisfies_newton_euler_balances_at_random_frames(run):
    """M u' - f(q, u, 0) - f_ext = G^T lambda + B tau, evaluated per frame from SystemEquations."""
    e, S = run.eqs, run.states
    f0 = ca.substitute(e.forces, e.inputs, ca.SX.zeros(e.inputs.shape))
    fn = ca.Function("balances", [e.q, e.u], [e.mass_matrix, f0, e.G.T, ca.jacobian(e.forces, e.inputs)])
    frames = np.random.default_rng(7).choice(len(run.t), 6, replace=False)
    for n in frames:
        M, f, GT, B = (np.asarray(x) for x in fn(S["q"][n], S["u"][n]))
        lhs = M @ S["udot"][n] - f.ravel() - S["fext"][n]
        rhs = GT @ run.lam[n] + B @ run.tau[n]
        np.testing.assert_allclose(rhs, lhs, atol=1e-8 * (1 + np.abs(lhs).max()))
    assert run.status == "solved" and run.residual.max() < 1e-8


def test_body_speeds_and_accelerations_match_finite_differences_of_the_poses(run):
    """u and u' of the run against central differences of the body poses along the splines."""
    fns = run.functions
    names = run.coordinate_names
    from ocp_constraints.biomech.gait_signals import filter_coordinates
    from ocp_constraints.biomech.opensim_files import read_motion

    trans = [n for n, c in run.osim.coordinates.items() if not c.rotational]
    splines = filter_coordinates(read_motion(G / "subject01_walk1_ik.mot", translational=trans), names, 6.0)
    com = np.concatenate([run.osim.bodies[b].com for b in fns.meta["bodies"]])
    nb = len(fns.meta["bodies"])

    def xbar(t):
        R, x = (np.asarray(a).ravel() for a in fns.poses(splines(t)[0][0]))
        Rs = R.reshape(nb, 3, 3).transpose(0, 2, 1)          # column major per body
        return x.reshape(nb, 3) + np.einsum("bij,bj->bi", Rs, com.reshape(nb, 3)), Rs

    h = 1e-4
    for n in (3, 17, 30):
        t = run.t[n]
        (xm, Rm), (x0, R0), (xp, Rp) = xbar(t - h), xbar(t), xbar(t + h)
        v_fd, a_fd = (xp - xm) / (2 * h), (xp - 2 * x0 + xm) / h ** 2
        W = np.einsum("bij,bkj->bik", (Rp - Rm) / (2 * h), R0)            # R' R^T
        w_fd = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
        u = run.states["u"][n].reshape(nb, 6)
        ud = run.states["udot"][n].reshape(nb, 6)
        # central differences err by h^2/6 times the third derivative: ~1e-6 here
        np.testing.assert_allclose(u[:, :3], v_fd, atol=1e-5 * (1 + np.abs(v_fd).max()))
        np.testing.assert_allclose(u[:, 3:], w_fd, atol=1e-5 * (1 + np.abs(w_fd).max()))
        np.testing.assert_allclose(ud[:, :3], a_fd, atol=2e-3 * (1 + np.abs(a_fd).max()))


def test_quaternions_vectorised_equal_the_scalar_shepperd_method():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(400, 3, 3))
    Q = np.linalg.qr(A)[0] * np.sign(np.linalg.det(np.linalg.qr(A)[0]))[:, None, None]
    Q[:4] = [np.eye(3), np.diag([1, -1, -1]), np.diag([-1, 1, -1]), np.diag([-1, -1, 1])]   # each branch
    expected = np.array([quaternion_from_rotation(R) for R in Q])
    np.testing.assert_allclose(quaternions(Q), expected, atol=1e-15)


def test_quintic_spline_equals_scipy_make_interp_spline_with_derivatives():
    from scipy.interpolate import make_interp_spline

    rng = np.random.default_rng(1)
    x = np.cumsum(rng.uniform(0.5, 1.5, 200)) * 0.01
    y = np.cumsum(rng.normal(size=(200, 3)), axis=0)
    xe = np.r_[x, rng.uniform(x[0], x[-1], 300)]
    ours, theirs = QuinticSpline.interpolate(x, y), make_interp_spline(x, y, k=5, axis=0)
    for nu in range(3):
        ref = theirs(xe, nu)
        np.testing.assert_allclose(ours(xe, nu), ref, atol=1e-11 * np.abs(ref).max())


def test_block_triangular_solve_equals_a_dense_solve_and_declines_what_it_cannot_do():
    rng = np.random.default_rng(2)
    # a permuted block-triangular pattern (blocks 1, 2, 3) with a random dense right-hand side
    L = np.zeros((6, 6))
    L[0, 0] = 2.0
    L[1:3, 0:3] = rng.normal(size=(2, 3))
    L[3:6, :] = rng.normal(size=(3, 6))
    L[1:3, 1:3] += 3 * np.eye(2)
    L[3:6, 3:6] += 3 * np.eye(3)
    rows, cols = rng.permutation(6), rng.permutation(6)
    A = L[rows][:, cols]
    nz = np.argwhere(A.T != 0)          # (column, row) in CasADi's column-major order
    a = ca.SX.sym("a", len(nz))
    As = ca.SX(6, 6)
    for k, (c, r) in enumerate(nz):
        As[r, c] = a[k]
    b = ca.SX.sym("b", 6)
    x = block_triangular_solve(As, b)
    f = ca.Function("f", [a, b], [x])
    rhs = rng.normal(size=6)
    got = np.asarray(f([A[r, c] for c, r in nz], rhs)).ravel()
    np.testing.assert_allclose(got, np.linalg.solve(A, rhs), rtol=1e-12)
    assert block_triangular_solve(ca.SX.sym("m", 3, 2), ca.SX.sym("r", 3)) is None          # not square
    singular = ca.SX(3, 3)
    singular[0, 0] = singular[1, 0] = singular[2, 2] = ca.SX.sym("s")
    assert block_triangular_solve(singular, ca.SX.sym("r", 3)) is None                     # sprank 2 < 3


def test_disk_cache_gives_the_same_functions_and_a_new_key_for_another_model(run, cache, tmp_path, monkeypatch):
    from ocp_constraints.biomech import gait_compiled

    built = run.functions
    assert run.settings["model"]["functions"] == "built"
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache))
    monkeypatch.setattr(gait_compiled, "_MEMO", {})
    assert gait_compiled.cache_file(built.key).is_file()
    loaded = gait_compiled._load(built.key)      # by the run's key (another helper's edit of the source would change it)
    assert isinstance(loaded, GaitFunctions) and loaded.source == "disk cache" and loaded.meta == built.meta
    args = [np.random.default_rng(4).normal(size=built.frame.size_in(i)) for i in range(built.frame.n_in())]
    for a, b in zip(built.frame(*args), loaded.frame(*args)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    other = tmp_path / "other.osim"
    other.write_bytes(Path(run.osim.path).read_bytes().replace(b"<mass>", b"<mass> ", 1))
    assert gait_compiled.model_key(other) != built.key


def test_chunked_evaluation_equals_one_map_over_all_frames(run, monkeypatch):
    from ocp_constraints.biomech import gait_compiled
    from ocp_constraints.mechanics.fast_eval import evaluate

    fns = run.functions
    monkeypatch.setattr(gait_compiled, "CHUNK", 16)
    monkeypatch.setattr(fns, "_maps", {})
    rng = np.random.default_rng(5)
    args = [rng.normal(size=(fns.frame.size_in(i)[0], 37)) for i in range(fns.frame.n_in())]     # 16 + 16 + 5
    for a, b in zip(fns.evaluate(fns.frame, *args), evaluate(fns.frame.map(37), *args)):
        np.testing.assert_array_equal(a, b)


def test_disk_cache_keeps_only_the_newest_model_files(run, tmp_path, monkeypatch):
    import os

    from ocp_constraints.biomech import gait_compiled

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    folder = gait_compiled.cache_file("x").parent
    folder.mkdir(parents=True)
    for k in range(gait_compiled.KEEP + 4):          # stale files of older keys, oldest first
        f = folder / f"gait_old{k:02d}.json"
        f.write_text("{}")
        os.utime(f, (1e9 + k, 1e9 + k))
    gait_compiled._save(run.functions)
    left = sorted(p.name for p in folder.glob("gait_*.json"))
    assert len(left) == gait_compiled.KEEP and gait_compiled.cache_file(run.functions.key).name in left
    assert "gait_old00.json" not in left and f"gait_old{gait_compiled.KEEP + 3:02d}.json" in left
