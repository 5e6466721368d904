"""OpenSim side of the knee muscle-path preprocessing (run by :mod:`.knee_model_data`).

Runs in its own process, ``python -m ocp_constraints.biomech.knee_paths_opensim MODEL OUT
[n] [seed]`` (the ``opensim`` wheel and ``casadi`` clash in one process; this module imports
neither CasADi nor the rest of the package). Loads a JW-type model, samples muscle-tendon lengths of the right-leg muscles over the
range of motion (OpenSim's own path computation: path points, conditional points and
wrap objects) and sweeps OpenSim's moment arms over knee angles.

The model's quadriceps paths (``recfem``, ``vasint``, ``vaslat``, ``vasmed``) run over
the patella *to the tibia*: they carry the force (their moment arms include the patellar
ligament). Their muscle-tendon units, to which ``optimal_fiber_length`` and
``tendon_slack_length`` belong, end on the patella: the model keeps them as the twins
``<name>_withreallength`` (same origin and parameters, no patellar-ligament segment). The
twins' lengths are sampled at the same poses (``unit_lengths``, ``unit_spans``).

The moment arms are sampled too, for every muscle and every coordinate its path spans, at
``ARM_FIT`` of the poses the lengths are fitted on and at ``ARM_HOLDOUT`` of the held-out ones
(``arm_indices``, ``moment_arms``). They are needed because for wrapped paths they are not the
derivative of the path length: the gastrocnemii wrap over an ellipsoid on the femur and a
cylinder on the tibia, and their OpenSim length has kinks where the wrapping switches, so
that ``-dL/dq`` differs from the force's moment arm by up to 25 mm in knee flexion (issue 15,
C3). :func:`~.knee_path_fits.fit_paths` fits lengths and moment arms jointly.

Which moment arm (issue 15's audit, ``scripts/knee_moment_arm_audit.py``,
``results/knee/moment_arm_audit.md``): the generalized force of a unit tension along OpenSim's
*current path* (:func:`string_moment_arms`: each straight segment pulls its two end points,
fixed in their bodies, towards each other; paper eqs. 35-41, ``Q = J^T F``; the wrap surface's
push on the string is the difference of the two pulls at its tangent points). ``computeMomentArm``
is the same sum with the points and directions of ``getPointForceDirections`` (reproduced to
1e-5 mm). For the gastrocnemii, whose path wraps over two objects (``Gastroc_at_Shank`` on the
tibia, then ``Gastroc_at_Condyles`` on the femur), the points it returns are not the current
path's (12 mm off at ngait_og5's frame 40) while the directions are, so the two forces of a
segment are not collinear and the tension, an internal force, has a net moment on the leg:
hip moment arms of up to 4.4 mm at the trials' poses where the path gives exactly 0, and 5.2 mm
of error about knee rotation. On the knee translations (where the point of application does not
matter) the two agree exactly. For every path with one wrap or none the two are the same. Until
issue 15's audit the fits followed ``computeMomentArm``.

A model without the coordinates sampled below exits with status 3 and a message naming them.
"""
import json
import sys

import numpy as np
import opensim as osim
osim.Logger.removeFileSink()   # else OpenSim writes opensim.log beside the model (in shared data)

PRIMARY = {  # coordinate: sampled range (rad); gait range of ngait_og5 plus a margin
    "hip_flexion": (-0.85, 0.60), "hip_adduction": (-0.30, 0.30), "hip_rotation": (-0.55, 0.15),
    "knee_flexion": (-1.40, 0.20), "ankle_angle": (-0.45, 0.45), "subtalar_angle": (-0.30, 0.30)}
SECONDARY = {"knee_adduction": 0.05, "knee_rotation": 0.05, "knee_tx": 0.003, "knee_ty": 0.003, "knee_tz": 0.003}
KNEE_TY = 0.042            # the JW model's default knee_ty (m); IK holds it there (read from the model)
PATELLA = ("patfem_flexion", "knee_flexion", 1.57)   # CoordinateCouplerConstraint patfem_flexion_con
UNIT = "_withreallength"    # recfem/vasint/vaslat/vasmed ending on the patella: their muscle-tendon units (below)
SKIP = (UNIT,)
ARM_FIT, ARM_HOLDOUT = 0.3, 0.1    # fractions of the samples where the moment arms are sampled (fit / held out)
TRUNK = ("ercspn", "intobl", "extobl")


def _vec(v):
    return np.array([v.get(0), v.get(1), v.get(2)])


def string_moment_arms(model, state, muscles, coords, set_pose, values, h=1e-6):
    """Generalized forces (m, or the share of the tension for a translation) of a unit tension along each
    muscle's current path about ``coords``, at the pose ``values`` (dict; ``set_pose(dict)`` poses and realizes
    the model): ``r_c = sum_i f_i . dx_i/dq_c`` with ``f_i`` the unit pulls of the segments at path point ``i``
    towards its neighbours and ``dx_i/dq_c`` the velocity of the material point under it, by central differences
    of ``h`` (the patella follows knee_flexion through ``set_pose``). Returns muscles x coords."""
    set_pose(values)
    stations, pulls = [], []
    for m in muscles:
        cp = model.getMuscles().get(m).getGeometryPath().getCurrentPath(state)
        x = [_vec(cp.get(i).getLocationInGround(state)) for i in range(cp.getSize())]
        st, f = [], []
        for i in range(len(x)):
            frame = cp.get(i).getParentFrame()
            local = frame.getTransformInGround(state).shiftBaseStationToFrame(osim.Vec3(*x[i]))
            st.append((frame, osim.Vec3(local.get(0), local.get(1), local.get(2))))
            pull = np.zeros(3)
            for j in (i - 1, i + 1):
                if 0 <= j < len(x) and np.linalg.norm(x[j] - x[i]) > 0:
                    pull += (x[j] - x[i]) / np.linalg.norm(x[j] - x[i])
            f.append(pull)
        stations.append(st)
        pulls.append(np.array(f))
    out = np.zeros((len(muscles), len(coords)))
    for k, c in enumerate(coords):
        moved = []
        for s in (1.0, -1.0):
            set_pose({**values, c: values[c] + s * h})
            moved.append([np.array([_vec(fr.findStationLocationInGround(state, p)) for fr, p in st]) for st in stations])
        for i in range(len(muscles)):
            out[i, k] = float(np.sum(pulls[i] * (moved[0][i] - moved[1][i]))) / (2 * h)
    set_pose(values)
    return out


def arms_at_poses(model_path, in_path, out_path):
    """Moment arms at given poses (issue 15's audit): ``in_path`` JSON ``{"names", "P" (poses x names), "muscles",
    "rows"}``; writes ``compute_moment_arm``, ``string`` (:func:`string_moment_arms`) and ``length_fd``
    (``-dL/dq``, central differences of OpenSim's path length), each poses x rows x muscles, and the lengths."""
    d = json.load(open(in_path))
    model = osim.Model(model_path)
    state = model.initSystem()
    cs = model.getCoordinateSet()
    for i in range(cs.getSize()):
        cs.get(i).setLocked(state, False)
    ms = model.getMuscles()
    names, muscles, rows = d["names"], d["muscles"], d["rows"]
    dep, indep, offset = PATELLA

    def set_pose(values):
        for c, v in values.items():
            if cs.contains(c):
                cs.get(c).setValue(state, float(v), False)
        cs.get(dep).setValue(state, float(values[indep]) + offset, False)
        model.realizePosition(state)

    P = np.asarray(d["P"], float)
    shape = (len(P), len(rows), len(muscles))
    cma, string, fd, L = np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros((len(P), len(muscles)))
    for n in range(len(P)):
        values = dict(zip(names, P[n]))
        set_pose(values)
        L[n] = [ms.get(m).getLength(state) for m in muscles]
        cma[n] = [[ms.get(m).computeMomentArm(state, cs.get(c)) for m in muscles] for c in rows]
        string[n] = string_moment_arms(model, state, muscles, rows, set_pose, values).T
        for j, c in enumerate(rows):
            h = 1e-5 if c in ("knee_tx", "knee_ty", "knee_tz") else 1e-4
            Lpm = []
            for s in (1.0, -1.0):
                set_pose({**values, c: values[c] + s * h})
                Lpm.append(np.array([ms.get(m).getLength(state) for m in muscles]))
            fd[n, j] = -(Lpm[0] - Lpm[1]) / (2 * h)
    json.dump({"opensim_version": osim.GetVersionAndDate(), "compute_moment_arm": cma.tolist(),
               "string": string.tolist(), "length_fd": fd.tolist(), "lengths": L.tolist()}, open(out_path, "w"))


def main(model_path, out_path, n=4000, seed=7):
    model = osim.Model(model_path)
    state = model.initSystem()
    cs = model.getCoordinateSet()
    missing = [c for c in [*PRIMARY, *SECONDARY, PATELLA[0]] if not cs.contains(c)]
    if missing:
        sys.stderr.write(f"{model_path}: no coordinate(s) {missing}: the knee preprocessing needs a JW-type "
                         "right knee (6-DOF knee with a coupled patella)\n")
        sys.exit(3)
    global KNEE_TY
    KNEE_TY = float(cs.get("knee_ty").getDefaultValue())
    for i in range(cs.getSize()):
        cs.get(i).setLocked(state, False)
    muscles = []
    ms = model.getMuscles()
    for i in range(ms.getSize()):
        name = ms.get(i).getName()
        if name.endswith("_l") or "_l_" in name or name.startswith(TRUNK) or any(s in name for s in SKIP):
            continue
        muscles.append(name)
    units = [m for m in muscles if ms.contains(m + UNIT)]
    dep, indep, offset = PATELLA

    def pose(values):
        full = {c: 0.0 for c in PRIMARY}
        full.update({c: 0.0 for c in SECONDARY})
        full["knee_ty"] = KNEE_TY
        full.update(values)
        full[dep] = full[indep] + offset
        for c, v in full.items():
            cs.get(c).setValue(state, float(v), False)
        model.realizePosition(state)

    def lengths():
        return [ms.get(m).getLength(state) for m in muscles]

    def unit_lengths():
        return [ms.get(m + UNIT).getLength(state) for m in units]

    rng = np.random.default_rng(seed)
    names = list(PRIMARY) + list(SECONDARY)
    X = np.zeros((n, len(names)))
    for j, c in enumerate(PRIMARY):
        X[:, j] = rng.uniform(*PRIMARY[c], n)
    for j, c in enumerate(SECONDARY):
        # half of the samples at the secondary origin (the poses of the IK), half perturbed
        X[:, len(PRIMARY) + j] = np.where(np.arange(n) % 2 == 0, 0.0, rng.uniform(-1, 1, n) * SECONDARY[c])
    X[:, names.index("knee_ty")] += KNEE_TY
    L = np.zeros((n, len(muscles)))
    LU = np.zeros((n, len(units)))
    for k in range(n):
        pose(dict(zip(names, X[k])))
        L[k] = lengths()
        LU[k] = unit_lengths()
    # which coordinates each muscle spans: finite differences at a few poses
    spans = {m: [] for m in muscles}
    unit_spans = {m: [] for m in units}
    for k in range(6):
        base = dict(zip(names, X[2 * k]))
        pose(base)
        L0, U0 = np.array(lengths()), np.array(unit_lengths())
        for c in names:
            h = 0.01 if c in PRIMARY or c in ("knee_adduction", "knee_rotation") else 0.001
            pose({**base, c: base[c] + h})
            d = np.abs(np.array(lengths()) - L0)
            for i, m in enumerate(muscles):
                if d[i] > 1e-7 and c not in spans[m]:
                    spans[m].append(c)
            d = np.abs(np.array(unit_lengths()) - U0)
            for i, m in enumerate(units):
                if d[i] > 1e-7 and c not in unit_spans[m]:
                    unit_spans[m].append(c)
    # OpenSim's moment arms about every spanned coordinate, at the first ARM_FIT * n poses (inside the
    # first 80 %, which the fit uses) and at ARM_HOLDOUT * n poses of the held-out last 20 %
    n_fit = int(0.8 * n)
    arm_idx = list(range(min(int(ARM_FIT * n), n_fit))) + list(range(n_fit, min(n_fit + int(ARM_HOLDOUT * n), n)))
    # (the string's generalized force, not computeMomentArm: module docstring)
    A = np.zeros((len(arm_idx), len(muscles), len(names)))
    for r, k in enumerate(arm_idx):
        A[r] = string_moment_arms(model, state, muscles, names, pose, dict(zip(names, X[k])))
    arm_columns = {}
    for i, m in enumerate(muscles):
        spanned = [c for c in names if c in spans[m]]
        arm_columns[m] = {"coordinates": spanned, "values": A[:, i, [names.index(c) for c in spanned]].tolist()}
    # moment arms about coordinates the length does not depend on (OpenSim's force application can give
    # them one, e.g. the gastrocnemii about the hip near extension): their largest values, for the record
    unspanned = {m: {} for m in muscles}
    for k in range(6):
        pose(dict(zip(names, X[2 * k])))
        for m in muscles:
            for c in names:
                if c not in spans[m]:
                    v = abs(ms.get(m).computeMomentArm(state, cs.get(c)))
                    unspanned[m][c] = max(unspanned[m].get(c, 0.0), v)
    # moment-arm sweep: knee angles, other coordinates at 0 (knee_ty at its default)
    sweep = np.radians(np.arange(-75.0, 10.01, 5.0))
    arms = {c: np.zeros((len(sweep), len(muscles))) for c in ("knee_flexion", "hip_flexion", "ankle_angle")}
    fd = np.zeros((len(sweep), len(muscles)))
    string = {c: np.zeros((len(sweep), len(muscles))) for c in arms}
    for k, q in enumerate(sweep):
        pose({"knee_flexion": q})
        for c in arms:
            arms[c][k] = [ms.get(m).computeMomentArm(state, cs.get(c)) for m in muscles]
        full = {c: 0.0 for c in names}
        full.update({"knee_ty": KNEE_TY, "knee_flexion": q})
        S = string_moment_arms(model, state, muscles, list(arms), pose, full)
        for j, c in enumerate(arms):
            string[c][k] = S[:, j]
        pose({"knee_flexion": q})
        h = 1e-5
        pose({"knee_flexion": q + h})
        Lp = np.array(lengths())
        pose({"knee_flexion": q - h})
        fd[k] = -(Lp - np.array(lengths())) / (2 * h)
    out = {"opensim_version": osim.GetVersionAndDate(), "model": model_path, "muscles": muscles,
           "coordinates": names, "patella_coupling": {"dependent": dep, "independent": indep, "offset": offset},
           "knee_ty": KNEE_TY, "samples": X.tolist(), "lengths": L.tolist(), "spans": spans,
           "sweep_knee_flexion": sweep.tolist(),
           "sweep_moment_arms": {c: a.tolist() for c, a in arms.items()},
           "sweep_moment_arms_string": {c: a.tolist() for c, a in string.items()},
           "sweep_moment_arm_knee_fd_coupled": fd.tolist(), "seed": seed,
           "units": units, "unit_suffix": UNIT, "unit_lengths": LU.tolist(), "unit_spans": unit_spans,
           "arm_indices": arm_idx, "moment_arms": arm_columns, "unspanned_moment_arms_max": unspanned}
    with open(out_path, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    if sys.argv[1] == "--at-poses":       # --at-poses MODEL IN.json OUT.json (the moment-arm audit)
        arms_at_poses(*sys.argv[2:5])
    else:
        main(sys.argv[1], sys.argv[2], *(int(a) for a in sys.argv[3:5]))
