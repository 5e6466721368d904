"""RMS tables of issue 6 (gait2354 subject01, JW ngait_og5) and wall times, files to results."""
import time
from pathlib import Path
from ocp_constraints.biomech.gait import compare, run_inverse_dynamics
from ocp_constraints.biomech.opensim_files import read_forces
ROOT = Path(__file__).resolve().parents[1]
D = ROOT.parent / "shared" / "data"; G = D / "opensim-gait2354-subject01"; J = D / "grand-challenge-knee-jw"
O46 = ROOT / "tests" / "data" / "gait2354_subject01_id_opensim46.sto"
ref = read_forces(G / "inverse_dynamics.sto")
t0 = time.perf_counter()
r = run_inverse_dynamics(G / "subject01_simbody.osim", G / "subject01_walk1_ik.mot", G / "subject01_walk1_grf.mot", times=ref.time)
print(f"gait2354: {time.perf_counter()-t0:.2f} s wall (timings {r.timings['total']:.2f} s)")
coords = [f"{j}_{s}" for s in "rl" for j in ("hip_flexion", "knee_angle", "ankle_angle")]
c1, c2 = compare(r, ref, r.coordinate_names), compare(r, read_forces(O46), r.coordinate_names)
print(f"{'coordinate':18s} {'vs shipped: N m':>15s} {'%':>6s}   {'vs OpenSim 4.6: N m':>19s} {'%':>6s}")
for k in coords:
    print(f"{k:18s} {c1[k]['rms']:15.3f} {c1[k]['percent']:6.2f}   {c2[k]['rms']:19.4f} {c2[k]['percent']:6.3f}")
print("max over all 23 vs OpenSim 4.6:", max(v['rms'] for v in c2.values()), "N m,", max(v['percent'] for v in c2.values()), "%")
refj = read_forces(J / "reducepoly_subject_GC" / "ID" / "ID_ngait_og5.mat")
cyc = (refj.time >= 2.178) & (refj.time <= 3.283)
t0 = time.perf_counter()
rj = run_inverse_dynamics(J / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim",
                          J / "reducepoly_subject_GC" / "IK" / "IK_ngait_og5.mat", J / "reducepoly_subject_GC" / "GRF" / "GRF_ngait_og5.mat", times=refj.time[cyc])
print(f"JW: {time.perf_counter()-t0:.2f} s wall (timings {rj.timings})")
for k, v in compare(rj, refj, ["knee_flexion", "knee_adduction", "knee_rotation", "knee_tx", "knee_ty", "knee_tz"]).items():
    print(f"{k:18s} {v['rms']:10.3f} {v['peak']:10.2f} {v['percent']:6.2f}")
print(rj.warnings)
