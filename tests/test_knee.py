"""Knee contact (issue 7): equipollence of the condyle pair, moment arms against OpenSim, sanity of the loads."""
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ocp_constraints.mechanics.equations import SystemEquations
from ocp_constraints.biomech import knee_model as km
from ocp_constraints.biomech.knee_contact import implant_geometry, stored_geometry
from ocp_constraints.biomech.knee_muscles import MusclePaths, muscle_parameters
from ocp_constraints.mechanics.rotations import EulerSequence

J = Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw"
IMPLANT_DIR = J / "workshop_bcn2024" / "ExperimentalData"   # the implant meshes (STL)
JW_MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
KNEE_MUSCLES = ["bflh", "bfsh", "grac", "recfem", "sart", "semimem", "semiten", "tfl", "vasint", "vaslat", "vasmed"]


def _rotation(axis, a):
    c, s = np.cos(a), np.sin(a)
    return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def test_jw_knee_coordinates_map_onto_the_tibias_321_angles_relative_to_the_femur():
    """R_FM = Rz(flexion) Rx(adduction) R_{-y}(rotation) (femur in the tray, JW model) <-> Q_T = R3 R2 R1 (paper)."""
    rng = np.random.default_rng(0)
    seq = EulerSequence("321")
    for _ in range(20):
        f, a, r = rng.uniform(-1.4, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-0.4, 0.4)
        p_fm = np.array([rng.uniform(-0.01, 0.01), rng.uniform(0.03, 0.05), rng.uniform(-0.01, 0.01)])
        R_fm = _rotation("z", f) @ _rotation("x", a) @ _rotation("y", -r)
        ang, origin = (np.asarray(v, float).ravel() for v in km.knee_pose(ca.DM([f, a, r, *p_fm])))
        Q = np.asarray(seq.rotation(ca.DM(ang)))
        np.testing.assert_allclose(Q, km.S.T @ R_fm.T @ km.S, atol=1e-14)        # the tibia relative to the femur
        np.testing.assert_allclose(-origin, Q @ (km.S.T @ p_fm), atol=1e-15)    # femoral origin from the tray origin
        np.testing.assert_allclose(km.jw_coordinates(ang, origin), [f, a, r, *p_fm], atol=1e-13)
    # psi = -knee_flexion when adduction = rotation = 0; psi > 0 moves the distal tibia posterior (+E2)
    ang, _ = km.knee_pose(ca.DM([-0.5, 0, 0, 0, 0.042, 0]))
    np.testing.assert_allclose(np.asarray(ang).ravel(), [0.5, 0, 0], atol=1e-15)
    assert float(seq.rotation(ang)[1, 0]) > 0


def _pair(p):
    model = km.knee_model(p)
    eqs = SystemEquations(model)
    femur, tibia = model.bodies["femur"], model.bodies["tibia"]
    centres = [km.condyle_centre(p, s) for s in km.SIDES]
    com_f = np.array([-p["com_height"], 0.0, 0.0])
    A = femur.point("A", 0.5 * (centres[0] + centres[1]) - com_f)         # joint point: midway on the flexion axis
    loads = {ch: eqs.load_about_function(ch, A) for ch in
             ("knee_medial@femur", "knee_lateral@femur", "knee_medial@tibia", "knee_lateral@tibia")}
    _, g, dual = km.relative_bases(femur, tibia)
    bases = ca.Function("bases", [eqs.q], [*g, *dual, tibia.Q @ ca.DM([-1.0, 0, 0]), A.position])
    return model, eqs, loads, bases, centres


def _poses(p):
    """Seated poses (both condyles on their plateaus) at several flexion and internal-external angles."""
    for psi, phi in ((0.0, 0.0), (0.6, 0.25), (1.2, -0.3), (-0.1, 0.4)):
        yield km.seated_pose(p, psi, phi)


@pytest.mark.parametrize("geometry", ["coaxial", "coaxial_varus", "coaxial_valgus", "fitted"])
def test_condyle_pair_is_one_force_plus_moment_along_g2(geometry):
    """Paper sec. 6: N_medial, N_lateral at the condyles == (N_medial + N_lateral) n_T plus a moment along g_2 = g^2.

    About A, midway between the condyle centres on the flexion axis: exact (1e-10) when the
    two condyle spheres share their sagittal centre (the paper's picture), in extension,
    flexion, with internal-external rotation and with the varus or valgus angle the plateau
    heights impose; with the fitted implant (centres 0.5 mm apart antero-posteriorly) the
    part off g_2 stays below 3 %. The tibia gets exactly the opposite load.
    """
    p = km.default_parameters()
    if geometry != "fitted":
        for a in ("cx", "cy"):
            p[f"medial_{a}"] = p[f"lateral_{a}"] = 0.5 * (p[f"medial_{a}"] + p[f"lateral_{a}"])
        p["medial_height"] += {"coaxial": 0.0, "coaxial_varus": 0.003, "coaxial_valgus": -0.004}[geometry]
    model, eqs, loads, bases, centres = _pair(p)
    names = eqs.constraint_names
    rng = np.random.default_rng(1)
    thetas = []
    for angles, origin in _poses(p):
        c = km.coordinates(p, angles, origin)
        q = np.array([c[n] for n in model.coordinate_names])
        phi = np.asarray(eqs.constraint_functions(q, np.zeros(eqs.nu), 0.0, [])[2]).ravel()
        assert np.abs(phi[:-1]).max() < 1e-12               # both condyles on their plateaus, tx, tz held
        assert phi[-1] == pytest.approx(angles[2], abs=1e-14)   # knee.ie: the relative phi (held at 0 in the scene)
        thetas.append(angles[1])
        lam = np.zeros(len(names))
        Nm, Nl = rng.uniform(100, 900, 2)
        lam[names.index("knee_medial.n")], lam[names.index("knee_lateral.n")] = Nm, Nl
        out = {ch: [np.asarray(v, float).ravel() for v in f(q, np.zeros(eqs.nu), 0.0, lam)] for ch, f in loads.items()}
        g1, g2, g3, d1, d2, d3, n, xA = (np.asarray(v, float).ravel() for v in bases(q))
        F = out["knee_medial@femur"][0] + out["knee_lateral@femur"][0]
        M = out["knee_medial@femur"][1] + out["knee_lateral@femur"][1]
        np.testing.assert_allclose(F, (Nm + Nl) * n, atol=1e-10 * (Nm + Nl))
        u2 = g2 / np.linalg.norm(g2)
        off = np.linalg.norm(M - (M @ u2) * u2)
        assert off < (1e-10 * np.linalg.norm(M) if geometry != "fitted" else 0.03 * np.linalg.norm(M)), (angles, M, g2)
        assert abs(M @ u2) > 1.0                # a real moment: the two forces differ and act ~22 mm either side
        np.testing.assert_allclose(d2, g2, atol=1e-14)                         # g_2 = g^2 for 3-2-1
        for ch, side, N in (("knee_medial", 0, Nm), ("knee_lateral", 1, Nl)):
            Ff, Mf = out[f"{ch}@femur"]
            Ft, Mt = out[f"{ch}@tibia"]
            np.testing.assert_allclose(Ff, N * n, atol=1e-10 * N)
            np.testing.assert_allclose(Ft, -Ff, atol=1e-10 * N)
            np.testing.assert_allclose(Mt, -Mf, atol=1e-10 * N)
            contact = centres[side] - p[f"{km.SIDES[side]}_radius"] * n
            np.testing.assert_allclose(Mf - np.cross(contact - xA, Ff), 0.0, atol=1e-10 * N)   # acts through the contact point
    if geometry == "coaxial_varus":
        assert min(thetas) > 0.03
    if geometry == "coaxial_valgus":
        assert max(thetas) < -0.04


def test_the_knee_scene_swings_on_compressed_condyles():
    """The scene (problems/knee.py) over its default horizon: residuals at tolerance, both contacts compressive."""
    from ocp_constraints import build_scene, consistent_state, simulate

    scene = build_scene("knee", {})
    eqs = SystemEquations(scene.model)
    q0, u0 = consistent_state(eqs, scene.coordinates, scene.rates)
    traj = simulate(eqs, q0, u0, 2.0)
    assert traj.sample("knee_medial.n.lambda").min() > 0 and traj.sample("knee_lateral.n.lambda").min() > 0
    assert np.ptp(traj.sample("tibia.psi")) > 0.5
    assert max(traj.residuals()) < 1e-9


@pytest.mark.parametrize("source", ["stored", "fitted"])
def test_implant_geometry_fits_the_meshes(source):
    """The condyle circles and plateau planes (stored with the package, and as ``implant_geometry``
    fits them now) against the workshop meshes themselves.

    Condyles: the sagittal (x, y) distances of each condyle's mesh points to its stored circle
    against those to the geometric best-fit circle (SciPy least_squares on the point-to-circle
    distances, another method than the package's algebraic fit). The condyles are J-curves, so
    no circle fits them closely (RMS 2.9 mm on both); the stored one must be within 1 % of the
    best RMS, its centre within 0.5 mm and radius within 0.1 mm of the geometric fit (measured:
    0.3 mm and 0.02 mm apart, the algebraic fit's bias). Plateaus: every vertex of each
    compartment lies on or above its plane Y = h, which touches the mesh. And the two meet: in
    the model's default pose (knee_ty from the .osim) each sphere's lowest point is within the
    fit's RMS of its plateau (measured gaps 1.3 and 1.1 mm).
    """
    import re

    from scipy.optimize import least_squares

    if not IMPLANT_DIR.is_dir():
        pytest.fail(f"{IMPLANT_DIR} is missing")
    g = stored_geometry() if source == "stored" else implant_geometry(IMPLANT_DIR).as_params()
    fem = np.loadtxt(IMPLANT_DIR / "femPoints_188.csv", delimiter=",", ndmin=2)
    tib = np.loadtxt(IMPLANT_DIR / "tibPoints_100.csv", delimiter=",", ndmin=2)
    osim = JW_MODEL.read_text()
    knee_ty = float(re.search(r'<Coordinate name="knee_ty">.*?<default_value>([^<]+)<', osim, re.S).group(1))
    for side, sign, faces in (("medial", 1.0, "facesTib1_100.csv"), ("lateral", -1.0, "facesTib2_100.csv")):
        pts = fem[fem[:, 2] * sign > 0]                       # +z is medial in the component frames
        assert len(pts) > 40
        centre, radius = np.array([g[f"{side}_cx"], g[f"{side}_cy"]]), g[f"{side}_radius"]
        stored_rms = np.sqrt(np.mean((np.linalg.norm(pts[:, :2] - centre, axis=1) - radius) ** 2))
        best = least_squares(lambda p: np.linalg.norm(pts[:, :2] - p[:2], axis=1) - p[2], [0.0, 0.0, 0.03])
        best_rms = np.sqrt(np.mean(best.fun**2))
        assert stored_rms <= 1.01 * best_rms, (side, stored_rms, best_rms)
        assert np.abs(centre - best.x[:2]).max() <= 5e-4 and abs(radius - best.x[2]) <= 1e-4, (side, best.x)
        # the circle's plane: among the condyle's distal points (within 3 mm of its lowest)
        distal = pts[pts[:, 1] < pts[:, 1].min() + 0.003]
        assert distal[:, 2].min() <= g[f"{side}_cz"] <= distal[:, 2].max()
        # the plateau plane Y = h supports the compartment's vertices from below and touches them
        plateau = tib[np.unique(np.loadtxt(IMPLANT_DIR / faces, delimiter=",", ndmin=2).astype(int) - 1)]
        assert np.all(plateau[:, 2] * sign > 0)
        height = g[f"{side}_height"]
        assert plateau[:, 1].min() - height == pytest.approx(0.0, abs=1e-12)
        gap = knee_ty + centre[1] - radius - height           # sphere bottom above the plateau, tray frame
        assert abs(gap) <= best_rms, (side, gap)


@pytest.fixture(scope="module")
def short_gait():
    from ocp_constraints.biomech.gait import run_inverse_dynamics
    t = np.linspace(2.3, 2.8, 12)
    return run_inverse_dynamics(JW_MODEL, J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat",
                                J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat", times=t)


def test_muscles_off_total_contact_equals_inverse_dynamics_reaction(short_gait):
    from ocp_constraints.biomech.knee_model import contact_matrix_function
    from ocp_constraints.biomech.knee_static import frame_data, solve_static
    paths = MusclePaths()
    Qc, R, A = frame_data(short_gait, paths, contact_matrix_function())
    F0 = np.full(len(paths.muscles), 1000.0)
    r = solve_static(short_gait.t, Qc, R, A, F0, muscles_on=False, contact_nonnegative=False)
    np.testing.assert_allclose(r.total, short_gait.loads["knee.knee_ty.lambda"], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(r.lam[:, 2], short_gait.loads["knee.knee_tx.lambda"], atol=1e-6)
    assert np.all(short_gait.loads["knee.knee_ty.lambda"] > 300)      # stance: compressive
    # with muscles the contact force adds the muscles' compression along the tibial axis
    F0 = np.array([muscle_parameters(JW_MODEL, paths.muscles)[m].max_isometric_force for m in paths.muscles])
    rm = solve_static(short_gait.t, Qc, R, A, F0)
    ty = 9   # row of knee_ty
    compression = -np.einsum("nm,nm->n", R[:, ty, :], rm.force)
    np.testing.assert_allclose(rm.total, short_gait.loads["knee.knee_ty.lambda"] + compression, rtol=1e-5, atol=1e-3)
    assert np.all(rm.medial >= -1e-6) and np.all(rm.lateral >= -1e-6)


def test_standing_frame_contact_is_the_weight_above_the_knee_plus_muscle_compression(tmp_path):
    """A static upright frame, half the body weight under each foot, the right CoP under the knee.

    The weight carried above the right knee reaches the tibia through the contact. In the model's
    default pose the tray is not level: its axis Y (the plateaus' normal, along which the
    condyle forces act) is 4.7 deg from the vertical (Y . up = 0.99657), so the two normal forces
    carry ``above (Y . up)`` and the shear multipliers ``ap`` (tray X) and ``ml`` (tray Z) the rest,
    ``above (X . up)`` and ``above (Z . up)`` (15.5 N each). Ignoring the tilt leaves a 0.34 %
    imbalance (0.23 % with muscles); with it the balance holds to 1.6e-12.
    """
    from ocp_constraints.biomech.gait import run_inverse_dynamics
    from ocp_constraints.biomech.knee_static import frame_data, solve_static
    from ocp_constraints.biomech.osim_model import load_osim

    osim = load_osim(JW_MODEL)
    names = osim.coordinate_names
    q = {n: 0.0 for n in names}
    q.update({"pelvis_ty": 1.0, "knee_ty": 0.042, "knee_ty_l": 0.042, "patfem_flexion": 1.57, "patfem_flexion_l": 1.57,
              "patfem_ty": 0.04, "patfem_ty_l": 0.04})
    X = osim.poses(q)
    t = np.linspace(0.0, 1.0, 121)
    deg = {n: (np.degrees(v) if osim.coordinates[n].rotational else v) for n, v in q.items()}
    (tmp_path / "ik.csv").write_text("time," + ",".join(names) + "\n" + "\n".join(
        f"{ti:.6f}," + ",".join(f"{deg[n]:.12g}" for n in names) for ti in t) + "\n")
    W = sum(b.mass for b in osim.bodies.values()) * float(np.linalg.norm(osim.gravity))
    knee_r, knee_l = (np.asarray(X[b][1], float).ravel() for b in ("tibial_tray", "tibia_l"))
    cols, rows = ["time"], []
    for k, c in ((1, knee_l), (2, knee_r)):
        cols += [f"grforce{k}_{a}" for a in ("fx", "fy", "fz", "px", "py", "pz", "tx", "ty", "tz")]
    for ti in t:
        rows.append([ti, 0, W / 2, 0, knee_l[0], 0, knee_l[2], 0, 0, 0, 0, W / 2, 0, knee_r[0], 0, knee_r[2], 0, 0, 0])
    (tmp_path / "grf.csv").write_text(",".join(cols) + "\n" + "\n".join(",".join(f"{v:.12g}" for v in r) for r in rows))
    gait = run_inverse_dynamics(JW_MODEL, tmp_path / "ik.csv", tmp_path / "grf.csv", times=np.array([0.4, 0.5, 0.6]))
    below = sum(osim.bodies[b].mass for b in ("tibial_tray", "tibia", "talus", "calcaneus", "toes"))
    above = W / 2 - below * float(np.linalg.norm(osim.gravity))          # weight carried above the right knee
    paths = MusclePaths()
    Qc, R, A = frame_data(gait, paths, km.contact_matrix_function())
    off = solve_static(gait.t, Qc, R, A, np.full(len(paths.muscles), 1000.0), muscles_on=False,
                       contact_nonnegative=False)
    up = -np.asarray(osim.gravity, float) / np.linalg.norm(osim.gravity)
    tray_up = np.asarray(X["tibial_tray"][0], float).T @ up              # up in the tray frame (X, Y, Z)
    assert 0.99 < tray_up[1] < 0.999                                     # tilted: the check below is not trivial
    np.testing.assert_allclose(off.total, above * tray_up[1], rtol=1e-9)
    np.testing.assert_allclose(off.lam[:, 2], above * tray_up[0], rtol=1e-9)     # ap shear along tray X
    np.testing.assert_allclose(off.lam[:, 3], above * tray_up[2], rtol=1e-9)     # ml shear along tray Z
    F0 = np.array([muscle_parameters(JW_MODEL, paths.muscles)[m].max_isometric_force for m in paths.muscles])
    on = solve_static(gait.t, Qc, R, A, F0)
    compression = -np.einsum("nm,nm->n", R[:, 9, :], on.force)
    assert np.all(compression >= -1e-6) and np.all(compression < 0.5 * W)
    np.testing.assert_allclose(on.total, above * tray_up[1] + compression, rtol=1e-9)
    assert np.all(on.medial > 0.2 * on.total) and np.all(on.lateral > 0.2 * on.total)   # both compartments loaded
