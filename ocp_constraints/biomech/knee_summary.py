"""The texts of the knee run's summary.json that describe the model: the passive moments and the muscles."""
from __future__ import annotations


def passive_text(name: str, passive, moments: dict | None = None, fibres: dict | None = None) -> dict:
    """summary.json's ``passive_hip``: the passive-moment model, its source and ranges (N m)."""
    if passive is None:
        return {"model": "none: the muscles (and reserves) carry the whole net hip flexion moment"}
    from .knee_passive import HIP_KNEE_ANKLE, SOURCE, SOURCE_ALL

    if name == HIP_KNEE_ANKLE:
        out = {"model": name, "source": SOURCE_ALL,
               "applied_to": "hip_flexion, knee_flexion and ankle_angle balances (muscles' share = Q - Q_passive)",
               "range_Nm": {c: [float(m.min()), float(m.max())] for c, m in (moments or {}).items()}}
    else:
        out = {"model": name, "source": SOURCE, "applied_to": "hip_flexion balance (muscles' share = Q - M_passive)",
               "range_Nm": [float(passive.min()), float(passive.max())]}
    if fibres:          # Hill muscles: their fibres carry part of the measured passive moment, counted once
        out["hill_fibres"] = ("the published moment is of all passive structures: the Hill fibres' passive "
                              "generalized force (fibre_range_Nm) is part of it, the joint-level torque (range_Nm) "
                              "is the rest, so fibres + joint-level = the published moment")
        out["fibre_range_Nm"] = {c: [float(m.min()), float(m.max())] for c, m in fibres.items()}
    return out


def muscle_model_text(run) -> dict:
    """summary.json's ``muscle_model``: the tension law, its parameters and the muscle-path fits."""
    data = run.get("model_data")
    paths = ("muscle-tendon lengths fitted to OpenSim's paths of this model file "
             f"({data.muscle_paths if data else 'ocp_constraints/biomech/data/jw_knee_muscle_paths.json'})")
    if run.get("muscle_model", "ideal") == "ideal":
        return {"name": "ideal", "tension": "F = a F0 (max_isometric_force from the model)", "paths": paths}
    h, r = run["hill"], run["result"]
    out = {"name": "hill", "tension": "F = F0 (a f_L f_V + f_PE) cos(alpha), rigid tendon",
           "curves": "De Groote et al. 2016, Ann Biomed Eng 44:2922 (doi:10.1007/s10439-016-1591-9)",
           "parameters": "max_isometric_force, optimal_fiber_length, tendon_slack_length, pennation_angle from the "
                         "model file; l_opt and l_s both scaled by k so that the fibre is at l_opt in the upright "
                         "reference pose (all angles zero); v_max = 10 l_opt/s",
           "length_scale_factor": getattr(h, "scale", None), "paths": paths, "fiber_length_range": {}}
    for i, m in enumerate(r.muscles):
        out["fiber_length_range"][m] = [float(h.fiber_length[:, i].min()), float(h.fiber_length[:, i].max())]
    return out
