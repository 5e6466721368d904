"""The knee pipeline: minimum-effort knee contact loads of a gait trial, compared with measured ones.

``run_knee`` chains inverse dynamics (:mod:`.gait`), the knee constraint matrix
(:mod:`.knee_model`), fitted muscle paths (:mod:`.knee_muscles`)
and static optimisation (:mod:`.knee_static`). The right gait cycle is found from the
force plates: the first two contact onsets (vertical force above 20 N) of plates
carrying the right foot. Measured loads (KCF: ``PM + AM`` medial, ``AL + PL`` lateral, lbf)
are converted with 4.4482216153 N/lbf and expressed in body weights (model mass x g).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import OcpConstraintsError
from .knee_options import METHOD_DEFAULT, METHOD_TEXT, METHODS, MUSCLE_MODELS, PASSIVE_DEFAULT, QUADRICEPS, QUADRICEPS_DEFAULT
from .knee_model import contact_matrix_function
from .knee_static import frame_data, solve_static
from .knee_summary import muscle_model_text as _muscle_model_text, passive_text as _passive_text
from ..errors import KneeError, KneeSolveError

LBF = 4.4482216153


def gait_cycle(grf, plates_of_right: list[str], name=None) -> tuple[float, float]:
    """First two right-foot contact onsets (s) in a force table (or file) ``grf``."""
    from .opensim_files import Table, grf_plates, read_grf

    grf_path = name if name is not None else getattr(grf, "path", grf)
    grf = grf if isinstance(grf, Table) else read_grf(grf)
    onsets = []
    for pl in grf_plates(grf):
        if pl.name in plates_of_right:
            on = np.flatnonzero(np.diff((pl.force[:, 1] > 20.0).astype(int)) == 1)
            onsets += [float(grf.time[i + 1]) for i in on]
    onsets.sort()
    if len(onsets) < 2:
        raise KneeError(f"{grf_path}: fewer than two right-foot contacts; no full gait cycle")
    return onsets[0], onsets[1]


def gait_phases(grf, plates_of_right: list[str], t0: float, t1: float) -> list[tuple[float, float, str]]:
    """``(start, end, "stance" | "swing")`` intervals of the right foot in ``t0 ... t1`` (s): stance where
    its plates' vertical force exceeds 20 N (the threshold of :func:`gait_cycle`)."""
    from .opensim_files import grf_plates

    loaded = np.zeros(len(grf.time), bool)
    for pl in grf_plates(grf):
        if pl.name in plates_of_right:
            loaded |= pl.force[:, 1] > 20.0
    keep = (grf.time >= t0) & (grf.time <= t1)
    t, on = grf.time[keep], loaded[keep]
    out, start = [], 0
    for i in range(1, len(t) + 1):
        if i == len(t) or on[i] != on[start]:
            out.append((float(t[start]), float(t[min(i, len(t) - 1)]), "stance" if on[start] else "swing"))
            start = i
    return out


def read_measured(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time (s), medial and lateral measured contact force (N) from a KCF file."""
    from .opensim_files import read_forces

    try:
        tab = read_forces(path)
    except OcpConstraintsError:
        raise
    except Exception as exc:  # noqa: BLE001 - unreadable file
        raise KneeError(f"{path}: cannot read the measured contact forces: {exc}") from exc
    cols = tab.columns
    missing = [c for c in ("PM", "AM", "AL", "PL") if c not in cols]
    if missing:
        raise KneeError(f"{path}: no column(s) {missing} (PM, AM, AL, PL in lbf are needed)")
    return tab.time, (cols["PM"] + cols["AM"]) * LBF, (cols["AL"] + cols["PL"]) * LBF


def compare(t, predicted: dict, measured, bw: float) -> dict:
    """RMSE (BW), Pearson r, R^2 (1 - SSE/SST) and peak error (BW) per channel, measured interpolated to ``t``.

    Only the frames that the measured record covers count (``frames_compared``); a record that
    covers fewer than two of them is a :class:`KneeError` naming both ranges."""
    tm, med, lat = measured
    ref = {"medial": med, "lateral": lat, "total": med + lat}
    half = 0.5 * float(np.median(np.diff(tm))) if len(tm) > 1 else 0.0
    keep = (t >= tm[0] - half) & (t <= tm[-1] + half)
    if keep.sum() < 2:
        raise KneeError(f"the measured loads cover {tm[0]:g} ... {tm[-1]:g} s, which is not the gait cycle "
                        f"{t[0]:g} ... {t[-1]:g} s: nothing to compare")
    t = np.asarray(t)[keep]
    out = {}
    for k, y in predicted.items():
        y = np.asarray(y)[keep]
        m = np.interp(t, tm, ref[k])
        flat = np.ptp(m) == 0 or np.ptp(y) == 0         # r and R^2 undefined for a constant curve: NaN
        out[k] = {"rmse_bw": float(np.sqrt(np.mean((y - m) ** 2)) / bw),
                  "r": float("nan") if flat else float(np.corrcoef(y, m)[0, 1]),
                  "r2": float("nan") if np.ptp(m) == 0 else float(1.0 - np.sum((y - m) ** 2) / np.sum((m - m.mean()) ** 2)),
                  "peak_error_bw": float((y.max() - m.max()) / bw), "peak_predicted_bw": float(y.max() / bw),
                  "peak_measured_bw": float(m.max() / bw), "frames_compared": int(keep.sum())}
    return out




class _Phases:
    """Wall and CPU time (s) of the steps of a run, in order: ``phase(name)`` closes the step ``name``."""

    def __init__(self):
        self.table: dict[str, dict[str, float]] = {}
        self._last = (time.perf_counter(), time.process_time())

    def __call__(self, name: str) -> None:
        now = (time.perf_counter(), time.process_time())
        self.table[name] = {"wall": now[0] - self._last[0], "cpu": now[1] - self._last[1]}
        self._last = now


def run_knee(model, motion, grf, measured=None, muscles_on: bool = True, muscle_model: str = "ideal",
             method: str = METHOD_DEFAULT, cutoff: float | None = 6.0, implant_meshes=None, build_model_data: bool = True,
             passive_hip: str = PASSIVE_DEFAULT, parameters: dict | None = None,
             quadriceps: str = QUADRICEPS_DEFAULT):
    """Gait cycle -> inverse dynamics -> static optimisation or collocation (-> comparison). Returns a dict.

    ``method``: ``"collocation"`` (the default since rule C17: the whole cycle with activation dynamics,
    :mod:`.knee_collocation`) or ``"static"`` (per-frame static optimisation, :mod:`.knee_static`, its
    fast-activation limit).

    ``muscle_model``: ``"ideal"`` (``F = a F0``, the default) or ``"hill"`` (De Groote et
    al. 2016 force-length-velocity curves, rigid tendon, :mod:`.knee_hill`; experimental: with
    a rigid tendon the quadriceps' passive forces reach 0.5-1 kN at zero activation in swing,
    which a subject who bends the knee in swing cannot have). With passive joint moments
    (``passive_hip`` not ``"none"``) the fibres' passive force is part of the published moment, not
    added to it: the joint-level torque is the published moment less the fibres' share
    (:func:`.knee_passive.less_fibre_passive`).

    The muscle-path fits and the implant geometry are those of the model *file*
    (:func:`.knee_model_data.knee_model_data`: by its SHA-256; built for a new model when
    OpenSim is installed and ``implant_meshes`` given, refused otherwise). The inverse
    dynamics runs once, on the samples of the right gait cycle only (the cycle is found from
    the plates that the inverse dynamics gives to the right foot).

    ``passive_hip``: ``"riener-edrich-1999-hip-knee-ankle"`` (default) takes the passive hip flexion,
    knee flexion and ankle plantarflexion moments of :mod:`.knee_passive` off the muscles' share of
    the hip_flexion, knee_flexion and ankle_angle balances; ``"riener-edrich-1999"`` only the hip's
    (issue 15's first round, candidate C5); ``"none"`` leaves
    the whole net moment to the muscles (and reserves).

    ``quadriceps``: ``"patellar-ligament"`` gives the vasti the central ligament line's moment arms on
    the locked knee directions (:mod:`.knee_quadriceps`); ``"model-paths"`` each head's own path.

    ``parameters``: condyle centres that replace the model file's (:func:`condyle_overrides`),
    e.g. for a sensitivity study of the condyle spacing.
    """
    from .knee_passive import PASSIVE_HIP

    overrides = condyle_overrides(parameters)

    if passive_hip not in PASSIVE_HIP:
        raise KneeError(f"unknown passive hip model '{passive_hip}' (use one of {', '.join(PASSIVE_HIP)})")
    if muscle_model not in MUSCLE_MODELS:
        raise KneeError(f"unknown muscle model '{muscle_model}' (use one of {', '.join(MUSCLE_MODELS)})")
    if quadriceps not in QUADRICEPS:
        raise KneeError(f"unknown quadriceps line '{quadriceps}' (use one of {', '.join(QUADRICEPS)})")
    if method not in METHODS:
        raise KneeError(f"unknown method '{method}' (use one of {', '.join(METHODS)})")
    if method == "collocation":
        from .knee_collocation import solve_collocation_or_static as solve
    else:
        solve = solve_static
    from .gait import run_inverse_dynamics
    from .knee_model import default_parameters
    from .knee_model_data import knee_model_data
    from .knee_muscles import MusclePaths, muscle_parameters

    # the measured loads first: a file that cannot be read fails before the optimisation, not after it
    meas = None if measured is None else read_measured(measured)
    clock = time.perf_counter()
    phase = _Phases()
    data = knee_model_data(model, implant_meshes, build=build_model_data)
    phase("model data")
    cycle = {}

    def right_cycle(plates, grf_table):
        right = [p for p, s in plates.items() if s == "right"]
        cycle["t"] = gait_cycle(grf_table, right, grf)
        cycle["phases"] = gait_phases(grf_table, right, *cycle["t"])
        return cycle["t"]

    gait = run_inverse_dynamics(model, motion, grf, cutoff=cutoff, select=right_cycle)
    phase("inverse dynamics")
    t0, t1 = cycle["t"]
    paths = MusclePaths(data.muscle_paths)
    phase("muscle paths")
    params = muscle_parameters(model, paths.muscles)
    F0 = np.array([params[m].max_isometric_force for m in paths.muscles])
    phase("muscle parameters")
    contact_A = contact_matrix_function({**default_parameters(), **data.geometry, **overrides})
    phase("contact matrix function")
    Qc, R, A = frame_data(gait, paths, contact_A)
    if quadriceps == "patellar-ligament":
        from .knee_quadriceps import patellar_ligament_arms

        R = patellar_ligament_arms(R, paths.muscles)
    phase("frame data")
    passive, moments, fibre_moments = None, {}, {}
    if passive_hip != "none":           # passive structures carry part of the net moments (Riener & Edrich 1999)
        from .knee_passive import passive_generalized_forces

        moments = passive_generalized_forces(passive_hip, gait.coordinate_names, gait.states["p"])
        passive = moments["hip_flexion"]
    hill = None
    if muscle_model == "hill":
        from .knee_hill import hill_forces, scale_lengths
        from .knee_static import muscle_kinematics

        L, V = muscle_kinematics(gait, paths)
        l_opt, l_s, alpha0 = (np.array([getattr(params[m], k) for m in paths.muscles]) for k in
                              ("optimal_fiber_length", "tendon_slack_length", "pennation_angle"))
        L_ref = np.asarray(paths.unit_length(paths.q_vector({}))).ravel()
        factors, l_opt, l_s = scale_lengths(L_ref, l_opt, l_s, alpha0)
        hill = hill_forces(L, V, F0, l_opt, l_s, alpha0)
        hill.scale = dict(zip(paths.muscles, factors.tolist()))
        if moments:     # Riener & Edrich measured ALL passive structures, the fibres' passive tension included
            from .knee_passive import less_fibre_passive

            moments, fibre_moments = less_fibre_passive(moments, R, hill.passive)
            passive = moments["hip_flexion"]
    if moments:         # the muscles' (and reserves') share of the balances: Q less the joint-level passive
        from .knee_passive import less_joint_passive

        Qc = less_joint_passive(Qc, moments)
    try:
        if hill is not None:
            res = solve(gait.t, Qc, R, A, hill.active, muscles_on=muscles_on, passive=hill.passive)
        else:
            res = solve(gait.t, Qc, R, A, F0, muscles_on=muscles_on)
    except KneeSolveError as exc:   # IPOPT failed: its last iterate is the result, success False (the CLI exits 1)
        res = exc.result
        if method != "static":
            res.fallback = f"{exc}; the loads are that static optimisation's last iterate"
    phase(method)
    res.muscles = paths.muscles
    bw = sum(b.mass for b in gait.osim.bodies.values()) * float(np.linalg.norm(gait.osim.gravity))
    out = {"result": res, "gait": gait, "cycle": (t0, t1), "phases": cycle["phases"], "bw": bw, "F0": F0, "hill": hill, "muscle_model": muscle_model,
           "method": method, "model_data": data, "quadriceps": quadriceps, "passive_hip": (passive_hip, passive),
           "passive_moments": moments, "fibre_passive_moments": fibre_moments,
           "wall_total": time.perf_counter() - clock, "step_times": phase.table}
    if meas is not None:
        out["measured"] = meas
        try:
            out["comparison"] = compare(res.t, {"medial": res.medial, "lateral": res.lateral, "total": res.total},
                                        meas, bw)
        except KneeError as exc:
            raise KneeError(f"{measured}: {exc}") from None
    return out


def write_knee_results(run: dict, out, plots: bool = True, inputs: dict | None = None, figure_process=None) -> dict:
    """Write the run folder ``out`` (loads.csv/.sto, muscle_forces.sto, trajectory.sto, summary.json and,
    with ``plots``, knee_contact.png and report.html); returns the summary. ``figure_process``: a
    :class:`~ocp_constraints.output.drawing_process.DrawingProcess` that draws the figure with matplotlib
    already loaded."""
    from ..output.files import software_versions, write_csv, write_json
    from ..output.report import write_report
    from ..output.run_folder import RunFolder
    from ..output.sto import write_sto

    run_folder = RunFolder(out)        # written whole: the previous run's files are replaced
    with run_folder.staged() as folder:
        # the figure first: a drawing process draws it while this process writes the tables (cli_knee ends the
        # process if this fails half-way); without one it is drawn here when its name is asked for
        figure = _plot_submit(run, folder, figure_process) if plots else None
        r = run["result"]
        passive_name, passive = run.get("passive_hip", ("none", None))
        cols = r.sample_columns()
        if passive is not None:
            cols["passive_hip_flexion_moment"] = passive
        for c, m in run.get("passive_moments", {}).items():     # generalized forces on the JW coordinates
            if c != "hip_flexion":
                cols[f"passive_{c}_generalized_force"] = m
        for c, m in run.get("fibre_passive_moments", {}).items():   # Hill: the fibres' share of Riener & Edrich's
            cols[f"fibre_passive_{c}_generalized_force"] = m
        write_csv(folder / "loads.csv", r.t, cols)
        write_sto(folder / "loads.sto", r.t, cols)        # OpenSim storage files (inDegrees=no)
        write_sto(folder / "muscle_forces.sto", r.t, {m: r.force[:, i] for i, m in enumerate(r.muscles)})
        g = run["gait"]
        if len(g.t) == len(r.t):
            write_sto(folder / "trajectory.sto", r.t, dict(zip(g.coordinate_names, g.states["p"].T)))
        from .knee_static import RESERVED

        method = "static" if r.fallback else run.get("method", "static")      # the loads' method, not the one asked
        summary = {"task": f"knee contact loads, {METHOD_TEXT[method]}", "method": method, "success": r.success,
                   "status": r.status, "fallback": r.fallback, "inputs": inputs or {},
                   "gait_cycle_s": list(run["cycle"]), "frames": len(r.t), "body_weight_N": run["bw"],
                   "solver": {"nlp": "all frames in one NLP, IPOPT (casadi.nlpsol)", "status": r.status,
                              "max_equation_residual": r.residual},
                   "wall_time_s": {**r.timings, "inverse_dynamics": run["gait"].timings.get("total"),
                                   "total": run["wall_total"]},
                   "filter": run["gait"].settings.get("filter"), "timing": run["gait"].settings.get("timing"),
                   "angles": run["gait"].settings.get("angles"), "warnings": run["gait"].warnings,
                   "model_data": run["model_data"].summary() if run.get("model_data") else None,
                   "muscle_model": _muscle_model_text(run), "quadriceps": run.get("quadriceps", "model-paths"),
                   "peak_reserve_Nm": {c: float(np.abs(r.reserve[:, i]).max()) for i, c in enumerate(RESERVED)},
                   "passive_hip": _passive_text(passive_name, passive, run.get("passive_moments", {}),
                                                run.get("fibre_passive_moments", {})),
                   "peak_bw": {"medial": float(r.medial.max() / run["bw"]), "lateral": float(r.lateral.max() / run["bw"]),
                               "total": float(r.total.max() / run["bw"])},
                   "comparison": run.get("comparison"), "software": software_versions()}
        if method == "collocation":
            from .knee_collocation import SMOOTHING

            summary["solver"]["transcription"] = ("first-order Radau IIA (backward Euler) collocation of the activation "
                                                  "ODE on the frames' time grid (the frames are the mesh)")
            summary["solver"]["max_activation_ode_residual"] = r.ode_residual
            summary["activation_dynamics"] = {
                "model": ("da/dt = (e - a)(e/tau_act + (1 - e)/tau_deact), Raasch et al. 1997, J Biomech 30:595"
                          if SMOOTHING == 0 else "da/dt = (e - a)/tau(e, a), De Groote et al. 2016, Ann Biomed Eng "
                          "44:2922 (doi:10.1007/s10439-016-1591-9), eqs. 1-2"),
                "initial_guess": "the static optimisation's solution (e = a)",
                "tau_act_s": r.tau[0], "tau_deact_s": r.tau[1], "smoothing_b": SMOOTHING,
                "objective": "int sum (e^2 + a^2)/2 + reserve_weight sum rho^2 dt (trapezoidal weights)"}
            summary["solve_time_s"] = r.timings["build"] + r.timings["solve"]
        if plots:
            summary["plots"] = [figure()]
            summary["report"] = "report.html"
        write_json(folder / "summary.json", summary)
        if plots:
            write_report(folder, summary)
    return summary




def _plot(run, folder, figure_process=None) -> str:
    """``knee_contact.png``: predicted and measured contact forces (BW), the gait phases shaded; drawn by
    ``figure_process`` if it can, else here."""
    return _plot_submit(run, folder, figure_process)()


def _plot_submit(run, folder, figure_process=None):
    """:func:`_plot` handed to ``figure_process`` now; returns the function that waits for its file name."""
    r, bw = run["result"], run["bw"]
    meas = run.get("measured")
    measured = None if meas is None else (meas[0], {"medial": meas[1] / bw, "lateral": meas[2] / bw,
                                                    "total": (meas[1] + meas[2]) / bw})
    label = f"{METHOD_TEXT[run.get('method', 'static')]}, {run.get('muscle_model', 'ideal')} muscles"
    args = (r.t, {"medial": r.medial / bw, "lateral": r.lateral / bw, "total": r.total / bw}, label,
            measured, list(run.get("phases", ())))
    from ..output.joint_plots import write_knee_figure

    if figure_process is not None:       # drawn there, or here if it cannot
        figure_process.submit(write_knee_figure, folder, *args)
        return figure_process.result
    return lambda: write_knee_figure(folder, *args)


CONDYLE_PARAMETERS = ("medial_cx", "medial_cy", "medial_cz", "lateral_cx", "lateral_cy", "lateral_cz")


def condyle_overrides(parameters: dict | None) -> dict[str, float]:
    """Condyle sphere centres (m, femoral component frame: x posterior, y proximal, z medial) that
    replace the implant geometry's (:mod:`.knee_contact`); the condyle spacing is ``medial_cz -
    lateral_cz``. Only the centres enter the contact loads' directions and moment arms (``A``,
    eq. 39): radii and plateau heights do not, so they are refused rather than silently ignored."""
    out = {}
    for name, value in (parameters or {}).items():
        if name not in CONDYLE_PARAMETERS:
            raise KneeError(f"knee parameter '{name}' is not one the contact loads depend on; use "
                            f"{', '.join(CONDYLE_PARAMETERS)} (condyle centres, m)")
        try:
            out[name] = float(value)
        except (TypeError, ValueError):
            out[name] = float("nan")
        if not np.isfinite(out[name]):
            raise KneeError(f"knee parameter '{name}' = {value!r} is not a finite number (m)")
    return out
