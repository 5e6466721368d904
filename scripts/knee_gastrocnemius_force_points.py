"""Issue 15's audit: where OpenSim applies the gastrocnemii's tension, against their own path (needs ``opensim``).

    python scripts/knee_gastrocnemius_force_points.py [--out results/knee/gastrocnemius_force_points.md]

Runs in the ``opensim`` process only (no CasADi; ``opensim`` and ``casadi`` clash in one process). At three
gait-cycle poses of ngait_og5 (loading response, mid-stance, terminal stance; knee at its locked values) and for
each gastrocnemius it writes:

* the current path's points (``getCurrentPath``) and the points and directions of ``getPointForceDirections``
  (PFD), the force system ``computeMomentArm`` applies (each in ground, mm);
* the net force and the net moment about the hip centre of that PFD force system for a unit tension: a tension
  along a string is internal to the leg, so both must be zero;
* ``computeMomentArm``, ``J^T`` of the PFD forces (velocities of their points by central differences), and the
  string's moment arm (``knee_paths_opensim.string_moment_arms``) about the hip and knee rotations (mm).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import opensim as osim
osim.Logger.removeFileSink()   # else OpenSim writes opensim.log beside the model (in shared data)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.knee_paths_opensim import PATELLA, string_moment_arms  # noqa: E402

MODEL = (ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_model"
         / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim")
POSES = {  # ngait_og5 frames 20, 40 and 60 of the gait cycle (rad), as in tests/test_knee_moment_arms.py
    "2.344 s": {"hip_flexion": 0.2208, "hip_adduction": 0.0707, "hip_rotation": -0.0749, "knee_flexion": -0.2218,
                "ankle_angle": -0.0145, "subtalar_angle": -0.1048},
    "2.511 s": {"hip_flexion": -0.0829, "hip_adduction": 0.1196, "hip_rotation": -0.1356, "knee_flexion": -0.0286,
                "ankle_angle": 0.1003, "subtalar_angle": -0.0828},
    "2.678 s": {"hip_flexion": -0.4057, "hip_adduction": 0.1414, "hip_rotation": -0.1579, "knee_flexion": 0.1237,
                "ankle_angle": 0.1996, "subtalar_angle": -0.076}}
ROWS = ["hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "knee_adduction", "knee_rotation"]


def vec(v) -> np.ndarray:
    return np.array([v.get(0), v.get(1), v.get(2)])


def main(out: Path) -> None:
    osim.Logger.setLevelString("error")
    model = osim.Model(str(MODEL))
    state = model.initSystem()
    cs = model.getCoordinateSet()
    for i in range(cs.getSize()):
        cs.get(i).setLocked(state, False)
    dep, indep, offset = PATELLA

    def set_pose(values):
        for c, v in values.items():
            cs.get(c).setValue(state, float(v), False)
        cs.get(dep).setValue(state, float(values[indep]) + offset, False)
        model.realizePosition(state)

    lines = [f"# Where OpenSim applies the gastrocnemii's tension ({osim.GetVersionAndDate()})", "",
             "`python scripts/knee_gastrocnemius_force_points.py`. Points in ground (mm). PFD: the points and "
             "directions of `getPointForceDirections`, which `computeMomentArm` applies.", ""]
    for label, p in POSES.items():
        values = {**{c: 0.0 for c in ("knee_adduction", "knee_rotation", "knee_tx", "knee_tz")}, "knee_ty": 0.042, **p}
        set_pose(values)
        hip = vec(model.getBodySet().get("femur").getPositionInGround(state))
        for m in ("gasmed", "gaslat"):
            mus = model.getMuscles().get(m)
            path = mus.getGeometryPath()
            cp = path.getCurrentPath(state)
            arr = osim.ArrayPointForceDirection()
            path.getPointForceDirections(state, arr)
            pfd = [(arr.get(i).frame(), osim.Vec3(arr.get(i).point()), vec(arr.get(i).direction()))
                   for i in range(arr.getSize())]
            lines += [f"## {m} at {label}", "", "| | path point (body) | PFD point (body) | PFD direction |",
                      "|---|---|---|---|"]
            for i in range(max(cp.getSize(), len(pfd))):
                a = (f"{np.round(1000 * vec(cp.get(i).getLocationInGround(state)), 1)} ({cp.get(i).getParentFrame().getName()})"
                     if i < cp.getSize() else "")
                b, d = "", ""
                if i < len(pfd):
                    fr, pt, dr = pfd[i]
                    b = f"{np.round(1000 * vec(fr.findStationLocationInGround(state, pt)), 1)} ({fr.getName()})"
                    d = f"{np.round(dr, 3)}"
                lines.append(f"| {i} | {a} | {b} | {d} |")
            force = sum(dr for _, _, dr in pfd)
            moment = sum(np.cross(vec(fr.findStationLocationInGround(state, pt)) - hip, dr) for fr, pt, dr in pfd)
            cma = np.array([mus.computeMomentArm(state, cs.get(c)) for c in ROWS])
            jt = np.zeros(len(ROWS))
            for k, c in enumerate(ROWS):
                moved = []
                for s in (1.0, -1.0):
                    set_pose({**values, c: values[c] + s * 1e-6})
                    moved.append([vec(fr.findStationLocationInGround(state, pt)) for fr, pt, _ in pfd])
                jt[k] = sum(dr @ (a - b) for (_, _, dr), a, b in zip(pfd, *moved)) / 2e-6
            set_pose(values)
            string = string_moment_arms(model, state, [m], ROWS, set_pose, values)[0]
            lines += ["", f"Net force of the PFD system for a unit tension {np.round(force, 12)}; net moment about "
                      f"the hip centre {np.round(1000 * moment, 2)} N mm (a string's tension is internal: both zero).",
                      "", "| moment arm (mm) | " + " | ".join(ROWS) + " |", "|---|" + "---|" * len(ROWS),
                      "| computeMomentArm | " + " | ".join(f"{1000 * v:+.2f}" for v in cma) + " |",
                      "| J^T of the PFD forces | " + " | ".join(f"{1000 * v:+.2f}" for v in jt) + " |",
                      "| string along the path | " + " | ".join(f"{1000 * v:+.2f}" for v in string) + " |", ""]
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee" / "gastrocnemius_force_points.md")
    main(ap.parse_args().out)
