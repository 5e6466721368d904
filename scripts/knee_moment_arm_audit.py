"""Issue 15's moment-arm audit: our fitted muscle paths against OpenSim at the three JW trials' own poses.

    python scripts/knee_moment_arm_audit.py --data R/ExampleTrackingSimulations/OpenSimModel/subject_GC \
        [--every 2] [--out results/knee] [--raw FILE] [--save-raw FILE]

For every muscle and every row the static optimisation balances (hip flexion / adduction / rotation, knee
flexion with the coupled patella, ankle, subtalar, and the knee's five locked directions), at the gait-cycle
frames of ngait_og5, bouncy7 and mtpgait3 (every ``--every``-th frame; none of them was a fitting pose: the fit
samples random poses of a box), three OpenSim values (``knee_paths_opensim --at-poses``, its own process):

* ``string``: the generalized force of a unit tension along OpenSim's current path, its own path points
  (``knee_paths_opensim.string_moment_arms``): the reference;
* ``computeMomentArm``: OpenSim's, which applies the tension at the points of ``getPointForceDirections``;
* ``-dL/dq``: central differences of OpenSim's path length (virtual work of a taut string).

and ours, ``-dP/dq`` of the fitted force paths (``MusclePaths.moment_arms_at``). Writes
``<out>/moment_arm_audit.md`` and ``.json``: the largest error per muscle and row (mm; on the translations the
share of the tension x 1000, and "mm-equivalent" x 22 mm, the condyles' lever). A defect is an error above
5 mm (translations: above 5 mm-equivalent).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from ocp_constraints.biomech.gait import run_inverse_dynamics  # noqa: E402
from ocp_constraints.biomech.knee_muscles import SECONDARY, MusclePaths  # noqa: E402
from ocp_constraints.biomech.knee_path_fits import LEVER, TRANSLATIONS  # noqa: E402
from ocp_constraints.biomech.knee_pipeline import gait_cycle  # noqa: E402
from ocp_constraints.biomech.knee_static import RESERVED  # noqa: E402

J = ROOT.parent / "shared" / "data" / "grand-challenge-knee-jw"
MODEL = J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
TRIALS = ("ngait_og5", "bouncy7", "mtpgait3")
ROWS = RESERVED + SECONDARY
DEFECT = 5e-3          # m (translations: share x LEVER)


def trial_poses(data: Path, every: int) -> dict:
    """The gait-cycle frames (every ``every``-th) of each trial: coordinate names and values."""
    out = {}
    for trial in TRIALS:
        folder = J / "reducepoly_subject_GC" if trial == "ngait_og5" else data
        files = [folder / k / f"{k}_{trial}.mat" for k in ("IK", "GRF")]

        def select(plates, grf):
            return gait_cycle(grf, [p for p, s in plates.items() if s == "right"])

        gait = run_inverse_dynamics(MODEL, *files, select=select)
        out[trial] = {"t": gait.t[::every].tolist(), "names": gait.coordinate_names,
                      "P": gait.states["p"][::every].tolist()}
    return out


def opensim_values(poses: dict, muscles: list[str]) -> dict:
    """OpenSim's three moment arms at the poses (knee_paths_opensim --at-poses, own process)."""
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for trial, p in poses.items():
            inp, out = Path(tmp) / f"{trial}_in.json", Path(tmp) / f"{trial}_out.json"
            inp.write_text(json.dumps({"names": p["names"], "P": p["P"], "muscles": muscles, "rows": ROWS}))
            run = subprocess.run([sys.executable, "-m", "ocp_constraints.biomech.knee_paths_opensim", "--at-poses",
                                  str(MODEL), str(inp), str(out)], cwd=ROOT, capture_output=True, text=True)
            if run.returncode:
                raise SystemExit(f"OpenSim at the {trial} poses failed:\n{run.stderr[-2000:]}")
            res[trial] = json.loads(out.read_text())
    return res


def ours(paths: MusclePaths, names: list[str], P) -> np.ndarray:
    """``-dP/dq`` of the fitted force paths at the poses: poses x ROWS x muscles."""
    P = np.asarray(P, float)
    Q = np.column_stack([P[:, names.index(c)] for c in paths.coordinates])
    R = paths.moment_arms_at(Q)
    return R[:, [paths.coordinates.index(c) for c in ROWS], :]


def audit(paths: MusclePaths, poses: dict, osim: dict) -> dict:
    """Largest absolute differences per muscle and row over all trials' poses (m, or share of the tension)."""
    cmp = {"ours": [], "compute_moment_arm": [], "length_fd": []}
    ref_all = []
    for trial, p in poses.items():
        ref = np.asarray(osim[trial]["string"])
        ref_all.append(ref)
        cmp["ours"].append(ours(paths, p["names"], p["P"]) - ref)
        cmp["compute_moment_arm"].append(np.asarray(osim[trial]["compute_moment_arm"]) - ref)
        cmp["length_fd"].append(np.asarray(osim[trial]["length_fd"]) - ref)
    out = {k: np.nanmax(np.abs(np.concatenate(v)), axis=0) for k, v in cmp.items()}     # rows x muscles
    out["reference_max_abs"] = np.nanmax(np.abs(np.concatenate(ref_all)), axis=0)
    return out


def lever(row: str) -> float:
    return LEVER if row in TRANSLATIONS else 1.0


def table(paths: MusclePaths, err: dict, title: str) -> list[str]:
    """Markdown: one line per muscle, one cell per row: ours / computeMomentArm / -dL/dq error (mm)."""
    lines = [f"### {title}", "",
             "Largest |error| against the string's moment arm over all poses, mm (translations: share x 1000); "
             "cells: ours / computeMomentArm / -dL/dq; **bold**: ours above 5 mm (translations: share x 22 mm "
             "above 5 mm). Blank: the muscle's fit does not span the row and OpenSim's values are all below "
             "0.01 mm. 'jump': -dL/dq across a jump of OpenSim's length (a wrap engaging).", "",
             "| muscle | " + " | ".join(ROWS) + " |", "|---|" + "---|" * len(ROWS)]
    for k, m in enumerate(paths.muscles):
        cells = []
        for j, c in enumerate(ROWS):
            e = [err[key][j, k] for key in ("ours", "compute_moment_arm", "length_fd")]
            if err["reference_max_abs"][j, k] < 1e-5 and max(e) < 1e-5:
                cells.append("")
                continue
            # OpenSim's length jumps where a wrap engages (addmagIsch): a difference across it is no arm
            text = " / ".join(f"{1000 * v:.1f}" if v < 10.0 else "jump" for v in e)
            cells.append(f"**{text}**" if e[0] * lever(c) > DEFECT else text)
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return lines


def defects(paths: MusclePaths, err: dict) -> list[tuple[str, str, float]]:
    return [(m, c, float(err["ours"][j, k])) for k, m in enumerate(paths.muscles) for j, c in enumerate(ROWS)
            if err["ours"][j, k] * lever(c) > DEFECT]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="ReducePoly_forMSK .../OpenSimModel/subject_GC")
    ap.add_argument("--every", type=int, default=2, help="every k-th frame of each gait cycle (default 2)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "knee")
    ap.add_argument("--raw", type=Path, help="poses and OpenSim values kept before (--save-raw)")
    ap.add_argument("--save-raw", type=Path)
    ap.add_argument("--paths", type=Path, help="muscle-path data file (default: the package's)")
    ap.add_argument("--tag", default="", help="suffix of the output files")
    args = ap.parse_args()
    clock, cpu = time.perf_counter(), time.process_time()
    paths = MusclePaths(args.paths) if args.paths else MusclePaths()
    if args.raw:
        raw = json.loads(args.raw.read_text())
    else:
        poses = trial_poses(args.data, args.every)
        raw = {"poses": poses, "opensim": opensim_values(poses, paths.muscles)}
    if args.save_raw:
        args.save_raw.write_text(json.dumps(raw))
    err = audit(paths, raw["poses"], raw["opensim"])
    n = sum(len(p["P"]) for p in raw["poses"].values())
    found = defects(paths, err)
    lines = [f"Moment-arm audit (`python scripts/knee_moment_arm_audit.py --data ... --every {args.every}`): "
             f"{n} poses of {', '.join(TRIALS)}; muscle paths `{Path(paths.path).name}`; "
             f"OpenSim {raw['opensim'][TRIALS[0]]['opensim_version']}.", "",
             f"Defects (ours above 5 mm): {len(found)}" + "".join(
                 f"\n- {m} about {c}: {1000 * e:.1f} " + ("share x 1000" if c in TRANSLATIONS else "mm")
                 for m, c, e in found), ""]
    lines += table(paths, err, "Every muscle x every balanced row")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"moment_arm_audit{args.tag}.md").write_text("\n".join(lines) + "\n")
    (args.out / f"moment_arm_audit{args.tag}.json").write_text(json.dumps(
        {"rows": ROWS, "muscles": paths.muscles, "poses": n, "max_abs_error": {k: v.tolist() for k, v in err.items()},
         "defects": found}, indent=1))
    print("\n".join(lines[:3 + len(found)]))
    print(f"{time.perf_counter() - clock:.1f} s wall, {time.process_time() - cpu:.1f} s CPU (this process)")


if __name__ == "__main__":
    main()
