"""Inverse dynamics of a measured gait trial with Lagrange's prescription.

Route (issue 6):

1. The OpenSim model's segments become our bodies (unit quaternions, so no Euler
   singularity). Every joint's six relative directions are written at velocity level
   from the bodies' angular velocities and point velocities: ``s_i' = g^i . R_F^T
   (omega_C - omega_P)`` for the three rotation axes (dual Euler basis of the joint,
   paper eq. 11) and ``s' = A^-1 R_F^T (v_M - v_F - omega_P x (x_M - x_F))`` for the
   translations. A direction with a constant function, a direction coupled to a
   coordinate by a spline (gait2354 knee translations) and a *locked* coordinate
   become named constraints of the core (``<joint>.<axis>``, ``<joint>.<coordinate>``);
   each free coordinate becomes an actuator input whose load pair has power
   ``tau q'`` (a torque along ``g^i`` or a force along the dual translation axis).
2. The coordinates are filtered as OpenSim's ID tool does (pad by reflection, 3rd-order
   Butterworth run forward and backward, i.e. zero phase, at 6 Hz; then interpolating
   quintic splines, differentiated twice) and the bodies' ``q, u, u'`` follow from
   forward kinematics with automatic differentiation.
3. Each force plate is given to the foot standing on it (centre of pressure against
   the feet found from the kinematics), applied to that foot's hindfoot body.
4. ``G^T lambda + B tau = M u' - f`` (the Newton-Euler balances, paper eq. 13) is
   solved at every sample; joint loads follow from Lagrange's prescription (eq. 26) and
   the generalized force of every OpenSim coordinate from ``Phi = lambda A`` with
   ``A = G dU/dpdot`` (eqs. 38-41) plus the inputs: for a locked coordinate
   ``Phi = lambda`` exactly (eq. 44). Steps 2's kinematics and 4 are one CasADi function
   of the frame, mapped over all frames in one evaluation, built once per model and kept
   on disk (:mod:`.gait_compiled`).

Modules: :mod:`.gait_model` (step 1), :mod:`.gait_signals` (2), :mod:`.gait_feet` (3),
:mod:`.gait_compiled` (the frame function and its cache), this one (4: the trial, :func:`run_inverse_dynamics`, :func:`compare`) and
:mod:`.gait_report` (results files; the ``gait`` command is :mod:`ocp_constraints.cli.gait`).

Checked against OpenSim 4.6's InverseDynamicsTool on gait2354 subject01: every one of
the 23 generalized forces agrees to 0.01 N m (``tests/test_gait.py``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..mechanics.equations import SystemEquations
from .gait_feet import Leg, assign_plates, find_legs
from .gait_model import JointInfo
from ..errors import GaitError
from .gait_signals import check_cutoff, filter_coordinates, motion_units, sample_period
from ..mechanics.fast_eval import evaluate
from ..dynamics.result import MechanicalResult
from ..mechanics.model import Model
from .opensim_files import Plate, Table, grf_plates, read_grf, read_motion
from ..errors import DataFileError
from .osim_model import OsimModel, load_osim
from .gait_compiled import GaitFunctions, gait_functions, quaternions

__all__ = ["GaitError", "GaitResult", "run_inverse_dynamics", "compare"]


class LoadTable(dict):
    """DESIGN.md's load columns by name; calling it (``result.loads()``) gives the same dict,
    the common vocabulary of :mod:`ocp_constraints.dynamics.result`. (Subscripting
    ``result.loads[...]`` directly is kept for the code written before that vocabulary.)"""

    def __call__(self) -> dict[str, np.ndarray]:
        return self


@dataclass
class GaitResult(MechanicalResult):
    """Inverse dynamics of a trial.

    ``generalized_forces`` (samples x coordinates) are in OpenSim's sense (N m for
    rotational, N for translational coordinates): inputs for free coordinates plus
    ``sum_k lambda_k A_k`` (eqs. 38-41) for every coordinate. ``loads()`` gives DESIGN.md's
    columns (``<constraint>.lambda``, ``<joint>@<body>.F_x`` ... in the ground frame), from
    :mod:`ocp_constraints.mechanics.load_columns`. ``sample(name)``: the bodies' coordinates
    and speeds, multipliers, inputs (named after their free coordinates, N m or N) and the
    generalized forces ``<coordinate>_moment`` / ``<coordinate>_force`` (the names of
    loads.csv); ``success``/``status`` those of the inverse-dynamics solve.
    """

    t: np.ndarray
    coordinate_names: list[str]
    generalized_forces: np.ndarray
    lam: np.ndarray
    tau: np.ndarray
    residual: np.ndarray
    load_table: LoadTable     # result.loads(): the common vocabulary
    joints: dict[str, JointInfo]
    legs: dict[str, Leg]
    plates: dict[str, str]
    timings: dict[str, float]
    warnings: list[str]
    osim: OsimModel
    functions: GaitFunctions = field(repr=False)
    states: dict[str, np.ndarray]
    status: str = "solved"
    success: bool = True
    settings: dict = field(default_factory=dict)   # filter, timing and unit decisions (summary.json)

    @property
    def constraint_names(self) -> list[str]:
        return list(self.functions.meta["constraints"])

    @property
    def input_names(self) -> list[str]:
        """The actuator inputs: one per free coordinate, named after it (N m or N)."""
        return list(self.functions.meta["inputs"])

    @property
    def model(self) -> Model:
        """Our constraint model of the OpenSim model (built on first use: 1-3 s; the run itself
        evaluates the cached frame functions of :mod:`.gait_compiled` and needs no model)."""
        return self.functions.model_and_equations(self.osim)[0]

    @property
    def eqs(self) -> SystemEquations:
        """The model's :class:`SystemEquations` (built on first use, as :attr:`model`)."""
        return self.functions.model_and_equations(self.osim)[1]

    def mechanical_samples(self):
        return self.eqs, self.t, self.states["q"], self.states["u"], self.lam, self.tau

    @property
    def loads(self) -> LoadTable:
        """DESIGN.md's load columns, computed once by the run; call it: ``result.loads()``."""
        return self.load_table

    def generalized_force_columns(self) -> dict[str, np.ndarray]:
        """``<coordinate>_moment`` (N m, rotational) or ``<coordinate>_force`` (N), as in loads.csv."""
        return {f"{c}{'_moment' if self.osim.coordinates[c].rotational else '_force'}": self.generalized_forces[:, i]
                for i, c in enumerate(self.coordinate_names)}

    def sample_columns(self) -> dict[str, np.ndarray]:
        return {**super().sample_columns(), **self.generalized_force_columns()}

    def generalized_force(self, coordinate: str) -> np.ndarray:
        if coordinate not in self.coordinate_names:
            raise GaitError(f"no coordinate '{coordinate}' (coordinates: {', '.join(self.coordinate_names)})")
        return self.generalized_forces[:, self.coordinate_names.index(coordinate)]

    def leg_joints(self, side: str) -> list[str]:
        """Names of the joints of one leg (hip to toes), in tree order."""
        bodies = set(self.osim.subtree(self.legs[side].chain[0]))
        return [n for n in self.osim.order if self.osim.outboard(self.osim.joints[n]) in bodies]


def _check_columns(osim: OsimModel, motion: Table) -> list[str]:
    names = osim.coordinate_names
    unknown = [n for n in motion.columns if n not in osim.coordinates]
    if unknown:
        raise GaitError(f"{motion.path}: coordinate(s) {unknown} are not in the model {osim.path}")
    missing = [n for n in names if n not in motion.columns]
    if missing:
        raise GaitError(f"{motion.path}: missing column(s) for the model coordinate(s) {missing}")
    return names


def _gap_check(table: Table, what: str, lo: float, hi: float) -> None:
    """A step of more than 3 median steps inside ``lo ... hi`` is a gap in the record: a clear error."""
    t = table.time
    steps = np.diff(t)
    dt = float(np.median(steps))
    inside = (t[1:] > lo) & (t[:-1] < hi)
    big = np.flatnonzero(inside & (steps > 3.0 * dt))
    if big.size:
        i = int(big[0])
        raise GaitError(f"{table.path}: the {what} record has a gap from {t[i]:g} to {t[i + 1]:g} s "
                        f"({steps[i]:g} s, the sample period is {dt:g} s) inside the window {lo:g} ... {hi:g} s")


def _gap_checks(motion: Table, grf: Table, lo: float, hi: float) -> None:
    _gap_check(motion, "motion", lo, hi)
    _gap_check(grf, "ground-reaction", lo, hi)


def _window(motion: Table, grf: Table, start, end, times, check_gaps: bool = True) -> tuple[np.ndarray, dict]:
    """Sample times, and what was done about the files' time ranges (recorded in summary.json).

    Files of one trial share a clock but may round it differently (one trial's force file
    starts at 1.39833 s, its motion file at 1.3983 s). Differences below half a sample
    period of the motion are accepted (the ground reactions are held at their end values
    over that sliver); otherwise the overlap of the two ranges is used. Only a window
    outside the overlap, or a gap inside a record, is an error, and it names both ranges.
    """
    if len(motion.time) < 6:        # the coordinates' quintic splines need 6 (one sample: no step to speak of)
        raise GaitError(f"the motion {motion.path} has {len(motion.time)} sample(s); at least 6 are needed "
                        f"(speeds and accelerations come from quintic splines through them)")
    dt = float(np.median(np.diff(motion.time)))
    tol = 0.5 * dt
    m0, m1, g0, g1 = float(motion.time[0]), float(motion.time[-1]), float(grf.time[0]), float(grf.time[-1])
    lo, hi = max(m0, g0), min(m1, g1)
    ranges = (f"the motion {motion.path} covers {m0:g} ... {m1:g} s, the ground reactions {grf.path} "
              f"cover {g0:g} ... {g1:g} s")
    if hi - lo < dt - 1e-12:
        raise GaitError(f"time ranges do not overlap: {ranges}")
    t0 = lo if start is None else float(start)
    t1 = hi if end is None else float(end)
    if not t0 < t1:
        raise GaitError(f"the requested window {t0:g} ... {t1:g} s is empty (start must be before end)")
    if t0 < lo - tol or t1 > hi + tol:
        raise GaitError(f"the requested window {t0:g} ... {t1:g} s is not inside the time both files cover "
                        f"({lo:g} ... {hi:g} s): {ranges}")
    if times is None:
        times = motion.time[(motion.time >= t0 - tol) & (motion.time <= t1 + tol)]
    times = np.asarray(times, float)
    if times.size == 0 or times.min() < lo - tol or times.max() > hi + tol:
        span = "no times" if times.size == 0 else f"times {times.min():g} ... {times.max():g} s"
        raise GaitError(f"time ranges do not match: {span} requested, but both files cover only "
                        f"{lo:g} ... {hi:g} s ({ranges})")
    if check_gaps:          # else checked on the window a caller selects (run_inverse_dynamics, select)
        _gap_checks(motion, grf, float(times.min()), float(times.max()))
    notes = []
    for edge, a, b in (("starts", m0, g0), ("ends", m1, g1)):
        d = a - b
        if 0 < abs(d) < tol:
            held = (d < 0) == (edge == "starts")      # the motion reaches past the ground reactions
            notes.append(f"the motion {edge} {abs(d):.3g} s {'before' if d < 0 else 'after'} the ground reactions "
                         f"(below half a sample period, {tol:.3g} s): accepted as the same instant"
                         + ("; the ground reactions are held at their "
                            + ("first" if edge == "starts" else "last") + " value over it" if held else ""))
        elif (d <= -tol) == (edge == "starts") and abs(d) >= tol:     # motion samples outside the forces
            notes.append(f"the motion {edge} at {a:g} s, the ground reactions at {b:g} s: only their overlap is used")
    f_grf, f_motion = 1.0 / sample_period(grf.time), 1.0 / sample_period(motion.time)
    if f_grf < f_motion / 1.5:      # forces sampled slower than the motion: between their samples they are interpolated
        notes.append(f"the ground reactions are sampled at {f_grf:.4g} Hz, slower than the motion's {f_motion:.4g} Hz: "
                     f"they are interpolated linearly between their samples, and a force's peak can fall between them")
    info = {"motion_s": [m0, m1], "ground_reactions_s": [g0, g1], "used_s": [float(times.min()), float(times.max())],
            "samples": int(times.size), "tolerance_s": tol,
            "rule": "time stamps that differ by less than half a motion sample period are the same instant; "
                    "the overlap of the files' time ranges is used",
            "notes": notes}
    return times, info


def run_inverse_dynamics(model_path, motion_path, grf_path, start: float | None = None, end: float | None = None,
                         cutoff: float | None = 6.0, times=None, select=None, compiled: str = "auto") -> GaitResult:
    """Inverse dynamics of a trial from files to joint loads (see the module docstring).

    Parameters
    ----------
    model_path, motion_path, grf_path
        ``.osim`` model, coordinates (IK output, any format of :mod:`.opensim_files`),
        ground reaction forces (one or more plates).
    start, end
        Window (s); default the whole motion.
    cutoff
        Low-pass cutoff for the coordinates (Hz), OpenSim's default 6; it must lie strictly
        between 0 and the Nyquist frequency of the motion (:func:`check_cutoff`). None: no
        filter (only on request: ``gait --no-filter``).
    times
        Sample times (s) to evaluate at (default: the motion's samples in the window).
    select
        Optional ``select(plates, grf) -> (t0, t1)``, called once the force plates are given
        to the feet (``plates``: plate name -> ``"right"``/``"left"``; ``grf`` the force table):
        only the samples in ``t0 ... t1`` are then solved (the knee's gait cycle), so the
        inverse dynamics runs once, on those samples only.
    compiled
        ``"auto"`` (the model's compiled frame function when one is cached), ``"always"``
        (compile it now if needed, once per model) or ``"never"``; see :mod:`.gait_compiled`.
    """
    clock = {"start": time.perf_counter()}
    osim = load_osim(model_path)
    trans = [n for n, c in osim.coordinates.items() if not c.rotational]
    motion = read_motion(motion_path, translational=trans)
    grf = read_grf(grf_path)
    names = _check_columns(osim, motion)
    # With a selection (the knee's gait cycle) only the selected window must be free of gaps: a record with a gap
    # elsewhere failed the knee (the plates are given to the feet at the force samples themselves)
    t, timing = _window(motion, grf, start, end, times, check_gaps=select is None)
    cutoff = check_cutoff(cutoff, motion)
    plates = grf_plates(grf)
    clock["read"] = time.perf_counter()
    fns = gait_functions(osim, compiled, frames=len(t))
    meta = fns.meta
    bodies = meta["bodies"]
    legs = find_legs(osim)
    clock["model"] = time.perf_counter()

    splines = filter_coordinates(motion, names, cutoff)

    # force plates -> feet (over the whole window, before any selection of samples)
    up = -np.asarray(osim.gravity) / np.linalg.norm(osim.gravity)
    in_window = (grf.time >= t.min() - 1e-9) & (grf.time <= t.max() + 1e-9)
    tg = grf.time[in_window]
    x_g = fns.evaluate(fns.poses, splines(tg)[0].T)[1]          # body origins, 3 n_bodies x samples
    feet = {}
    for s_, leg in legs.items():
        heel, toe = (bodies.index(leg.chain[c]) for c in (-2, -1))
        feet[s_] = (x_g[3 * heel:3 * heel + 3].T, x_g[3 * toe:3 * toe + 3].T)
    window_plates = [Plate(p.name, p.force[in_window], p.point[in_window], p.torque[in_window], p.columns) for p in plates]
    assigned = assign_plates(window_plates, feet, up, str(grf.path))
    if select is not None:          # e.g. the knee's gait cycle, found from the plates of one foot
        lo, hi = select(assigned, grf)
        if lo < t[0] - timing["tolerance_s"] or hi > t[-1] + timing["tolerance_s"]:
            raise GaitError(f"the selected window {lo:g} ... {hi:g} s reaches past the time both files cover "
                            f"({t[0]:g} ... {t[-1]:g} s): the motion {motion_path} and the ground reactions "
                            f"{grf_path} must both cover it")
        _gap_checks(motion, grf, float(lo), float(hi))
        t = t[(t >= lo - 1e-9) & (t <= hi + 1e-9)]
        if len(t) < 2:
            raise GaitError(f"{motion_path}: fewer than two motion samples in the selected window {lo:g} ... {hi:g} s")
        timing.update(selected_s=[float(lo), float(hi)], used_s=[float(t[0]), float(t[-1])], samples=int(len(t)))

    P, Pd, Pdd = splines(t)
    N, nb = len(t), len(bodies)
    R = fns.evaluate(fns.poses, P.T)[0]                                    # 9 n_bodies x samples, column major
    quat = quaternions(R.T.reshape(N, nb, 3, 3).transpose(0, 1, 3, 2))    # samples x bodies x 4
    clock["kinematics"] = time.perf_counter()
    F, M_O = np.zeros((N, nb, 3)), np.zeros((N, nb, 3))     # ground loads per body: force, moment about O
    for pl in plates:
        if pl.name not in assigned:
            continue
        k = bodies.index(legs[assigned[pl.name]].foot)
        Fp = np.column_stack([np.interp(t, grf.time, pl.force[:, i]) for i in range(3)])
        cop = np.column_stack([np.interp(t, grf.time, pl.point[:, i]) for i in range(3)])
        Tp = np.column_stack([np.interp(t, grf.time, pl.torque[:, i]) for i in range(3)])
        F[:, k] += Fp
        M_O[:, k] += np.cross(cop, Fp) + Tp
    clock["grf"] = time.perf_counter()

    # every frame at once: kinematics, balances (eq. 13), Phi = lambda A + tau (eqs. 38-41), joint loads
    q, u, ud, fext, lam, tau, gen, residual, values = (a.T for a in fns.evaluate(
        fns.frame, P.T, Pd.T, Pdd.T, quat.reshape(N, 4 * nb).T, F.reshape(N, 3 * nb).T,
        M_O.reshape(N, 3 * nb).T, t[None, :]))
    residual = residual.ravel()
    fns.check_determined(q[0], u[0], t[0], model_path)
    finite = np.isfinite(lam).all(axis=1) & np.isfinite(tau).all(axis=1) & np.isfinite(residual)
    if not finite.all():       # singular at a later frame (the rank check saw the first)
        n = int(np.flatnonzero(~finite)[0])
        raise GaitError(f"{model_path}: the balances are singular at t = {t[n]:g} s (frame {n}): the joint loads "
                        "are not determined there; check the motion for a joint at a singular configuration")
    worst = float(residual.max(initial=0.0))
    # as InverseDynamics: exact when the residual is below EXACT times the balances' scale
    exact = worst <= EXACT or worst <= EXACT * max(1.0, fns.balance_scale(q, u, ud, t, fext))
    status = "solved" if exact else f"least squares: largest equation residual {worst:.3g} (N, N m)"
    clock["solve"] = time.perf_counter()
    cols = meta["load_columns"]
    nc = len(meta["constraints"])
    loads = LoadTable({name: lam[:, k] for k, name in enumerate(cols[:nc])})
    loads.update({name: values[:, k] for k, name in enumerate(cols[nc:])})
    clock["loads"] = time.perf_counter()
    steps = ["read", "model", "kinematics", "grf", "solve", "loads"]
    prev, timings = clock["start"], {}
    for s_ in steps:
        timings[s_] = clock[s_] - prev
        prev = clock[s_]
    timings["total"] = clock["loads"] - clock["start"]
    joints = {n: JointInfo(n, j["parent"], j["child"], list(j["constraints"]), list(j["inputs"]))
              for n, j in meta["joints"].items()}
    states = _States(osim, bodies, {"q": q, "u": u, "udot": ud, "p": P, "pdot": Pd, "pddot": Pdd, "fext": fext})
    warnings = [w.replace("{osim_path}", str(osim.path)) for w in meta["warnings"]]
    warnings += [f"{grf.path}: {pl.name} has no free-torque column(s) {', '.join(m)}: taken as zero" for pl in plates
                 if (m := [a for a in ("torque_x", "torque_y", "torque_z") if a not in pl.columns])]
    model_info = {"functions": fns.source, "compiled": fns.compiled, "key": fns.key,
                  "operations_per_frame": meta.get("instructions")}
    return GaitResult(t, names, gen, lam, tau, residual, loads, joints, legs, assigned, timings, warnings, osim, fns,
                      states, status=status, success=True,
                      settings={"filter": splines.settings, "timing": timing, "angles": motion_units(motion),
                                "model": model_info})


EXACT = 1e-9       # relative residual below which the balances count as solved exactly (as InverseDynamics)


class _States(dict):
    """The states of a run; ``"J"`` (``d(vbar, omega)/d(pdot)`` per sample, eq. 39) is made on first use."""

    def __init__(self, osim: OsimModel, bodies: list[str], states: dict):
        super().__init__(states)
        self._osim, self._bodies = osim, bodies

    def __missing__(self, key):
        if key != "J":
            raise KeyError(key)
        P, Pd, Pdd = self["p"], self["pdot"], self["pddot"]
        N = len(P)
        J = evaluate(self._osim.kinematics_function(self._bodies).map(N), P.T, Pd.T, Pdd.T)[6]
        self["J"] = J.reshape(J.shape[0], N, P.shape[1]).transpose(1, 0, 2)
        return self["J"]


def compare(result: GaitResult, reference: Table, coordinates: list[str]) -> dict[str, dict[str, float]]:
    """RMS difference from OpenSim's generalized forces (``<coord>_moment`` / ``_force``).

    The reference is interpolated to the result's times. Returns per coordinate
    ``rms`` (N m or N), ``peak`` (largest magnitude of the reference) and ``percent``.
    """
    out = {}
    for c in coordinates:
        col = next((n for n in (f"{c}_moment", f"{c}_force") if n in reference.columns), None)
        if col is None:
            raise DataFileError(reference.path, f"has no column '{c}_moment' or '{c}_force'")
        ref = np.interp(result.t, reference.time, reference.columns[col])
        diff = result.generalized_force(c) - ref
        rms, peak = float(np.sqrt(np.mean(diff ** 2))), float(np.max(np.abs(ref)))
        out[c] = {"rms": rms, "peak": peak, "percent": 100 * rms / peak if peak > 0 else float("nan")}
    return out


