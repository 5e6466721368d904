"""The message's advice for the pendulum at 1e-6 ("Put a mesh point at the switch (Radau(mesh=...))"): refine from a
mesh with points at the junctions, (a) as the message gives them (fractions rounded to 3 digits), (b) at the reference's
junctions (ref_pend.npz, which the library cannot know).   python pend_mesh_at_junction.py [TOL]"""
import json, os, sys, time
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import models as M
import nc5
import ocp_constraints as oc

tol = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-6
ref = nc5.with_body_states("pend", np.load(os.path.join(nc5.HERE, "ref_pend.npz"), allow_pickle=True)["ref"].item())
sol0 = M.pend_force().solve(tolerance=1e-4)
found = [s for h in sol0.mesh_refinement["history"] for s in (h.get("switches") or [])]
print("switches recorded in the 1e-4 history:", json.dumps(found, default=str)[:600])
for label, js in (("message's 3 digits", [0.398, 0.545]), ("reference junctions", ref["junctions"])):
    mesh = np.unique(np.r_[np.linspace(0, 1, 11), js])
    c0 = time.process_time()
    try:
        sol = M.pend_force().solve(oc.Radau(len(mesh) - 1, mesh=tuple(mesh), degree=5), tolerance=tol)
    except Exception as exc:  # noqa: BLE001
        print(label, "raised", type(exc).__name__, str(exc)[:300]); continue
    cpu = time.process_time() - c0
    mr = sol.mesh_refinement; e = nc5.errors(sol, "pend", ref)
    print(f"{label} {np.round(js, 8).tolist()}: met {mr['met']}, {sol.transcription.scheme.point_count} points, CPU {cpu:.1f} s; "
          f"estimate {mr['estimate']['states']:.2e} / {mr['estimate']['multipliers']:.2e}, true {e['states']:.2e} / "
          f"{e['multipliers']:.2e} at {e['where']}")
    print("   ", mr["message"][:400])
