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

OpenSim's own moment arms (``computeMomentArm``: the generalized force of a unit tension,
the way OpenSim applies the muscle's force) are sampled too, for every muscle and every
coordinate its path spans, at ``ARM_FIT`` of the poses the lengths are fitted on and at
``ARM_HOLDOUT`` of the held-out ones (``arm_indices``, ``moment_arms``). They are needed
because for wrapped paths they are not the derivative of the path length: the gastrocnemii
wrap over an ellipsoid on the femur and a cylinder on the tibia, and their length has a
kink where the wrapping switches (near 35 and 20 degrees of knee flexion), so that
``-dL/dq`` differs from ``computeMomentArm`` by up to 25 mm in knee flexion (issue 15,
C3). :func:`~.knee_muscles.fit_paths` fits lengths and moment arms jointly.

A model without the coordinates sampled below exits with status 3 and a message naming them.
"""
import json
import sys

import numpy as np
import opensim as osim

PRIMARY = {  # coordinate: sampled range (rad); gait range of ngait_og5 plus a margin
    "hip_flexion": (-0.85, 0.60), "hip_adduction": (-0.30, 0.30), "hip_rotation": (-0.55, 0.15),
    "knee_flexion": (-1.40, 0.20), "ankle_angle": (-0.45, 0.45), "subtalar_angle": (-0.30, 0.30)}
SECONDARY = {"knee_adduction": 0.05, "knee_rotation": 0.05, "knee_tx": 0.003, "knee_ty": 0.003, "knee_tz": 0.003}
KNEE_TY = 0.042            # the JW model's default knee_ty (m); IK holds it there (read from the model)
PATELLA = ("patfem_flexion", "knee_flexion", 1.57)   # CoordinateCouplerConstraint patfem_flexion_con
UNIT = "_withreallength"    # recfem/vasint/vaslat/vasmed ending on the patella: their muscle-tendon units (below)
SKIP = (UNIT,)
ARM_FIT, ARM_HOLDOUT = 0.3, 0.1    # fractions of the samples where computeMomentArm is sampled (fit / held out)
TRUNK = ("ercspn", "intobl", "extobl")


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
    pairs = [(ms.get(m), cs.get(c)) for m in muscles for c in names if c in spans[m]]
    A = np.zeros((len(arm_idx), len(pairs)))
    for r, k in enumerate(arm_idx):
        pose(dict(zip(names, X[k])))
        A[r] = [m.computeMomentArm(state, c) for m, c in pairs]
    arm_columns, col = {}, 0
    for m in muscles:
        spanned = [c for c in names if c in spans[m]]
        arm_columns[m] = {"coordinates": spanned, "values": A[:, col:col + len(spanned)].tolist()}
        col += len(spanned)
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
    for k, q in enumerate(sweep):
        pose({"knee_flexion": q})
        for c in arms:
            arms[c][k] = [ms.get(m).computeMomentArm(state, cs.get(c)) for m in muscles]
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
           "sweep_moment_arm_knee_fd_coupled": fd.tolist(), "seed": seed,
           "units": units, "unit_suffix": UNIT, "unit_lengths": LU.tolist(), "unit_spans": unit_spans,
           "arm_indices": arm_idx, "moment_arms": arm_columns, "unspanned_moment_arms_max": unspanned}
    with open(out_path, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(int(a) for a in sys.argv[3:5]))
