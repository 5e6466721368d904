"""Where the estimate of a mesh refinement is not trusted: intervals whose inputs or multipliers are not smooth
(issue 19). A jump inside an interval (a bang-bang input's switch that no bound located) is resolved by the
companion no better than by the solution, so their difference is no upper bound there: such intervals withdraw
"met" (:func:`flag_nonsmooth`) or, while the estimate is met, are halved (:func:`nonsmooth_splits`). Used by
:mod:`.mesh_refinement`."""
from __future__ import annotations

import numpy as np

from .junction_floors import floored_kinks
from .legendre_decay import DECAY_LIMIT
from .switch_detection import penalized_inputs

MIN_INTERVAL = 1e-6     # fraction of the horizon below which an interval is not split further


def _untrusted(sol, tol: float, smoothness: tuple, windows) -> tuple[np.ndarray, np.ndarray]:
    """The mesh (fractions), and per interval whether its inputs or multipliers are not smooth (Legendre decay above
    :data:`.legendre_decay.DECAY_LIMIT`), its last term above ``tol``, and its middle outside every jump window."""
    decay, tail = smoothness
    mesh = sol.transcription.scheme.mesh_fractions
    mid = (mesh[:-1] + mesh[1:]) / 2
    in_window = np.zeros(len(mid), bool)
    for lo, hi in windows:
        in_window |= (mid > lo) & (mid < hi)
    return mesh, (decay > DECAY_LIMIT) & (tail > tol) & ~in_window


def merged_windows(windows) -> list[tuple[float, float]]:
    """``windows`` (``(from, to)`` fractions) in time order, those that overlap or touch as one, at full precision:
    two jumps in one mesh interval gave the same window twice, and windows rounded to 9 digits put the point closing
    one 4e-10 outside it (a newcomer's minimum-time rod)."""
    merged: list[list[float]] = []
    for lo, hi in sorted((float(lo), float(hi)) for lo, hi in windows):
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return [(lo, hi) for lo, hi in merged]


# How flag_nonsmooth's clauses start in a message: written with these, cut off by them (unflagged).
JUMPS = "; the inputs and multipliers jump (bang-bang) within "
UNTRUSTED = {True: ", but not trusted: ", False: "; and the estimate is not trusted: "}     # after a "met" message or not
CLAUSES = (JUMPS, *UNTRUSTED.values())


def unflagged(message: str) -> str:
    """``message`` without what :func:`flag_nonsmooth` added to it (it adds at the end, so all from its first clause on)."""
    cut = [message.find(c) for c in CLAUSES if c in message]
    return message[: min(cut)] if cut else message


def flag_nonsmooth(sol, tol: float, record: dict, smoothness: tuple, windows=()) -> None:
    """Withdraw "met" where the estimate cannot be trusted (and say so where it is not met either):
    intervals whose inputs or multipliers are not smooth (their Legendre coefficients fall no faster
    than half a step's, :func:`.legendre_decay.legendre_decay`) and whose polynomial's last term is
    larger than the tolerance. There a jump (a switch of a bang-bang input) sits inside the
    interval, the companion resolves it no better than the solution, and their difference is no
    upper bound (minimum-time swing-up: true state error 2.5x the estimate; the bench). The
    intervals are named in ``nonsmooth_intervals`` and the message; the solution is kept.

    Except inside ``windows`` (:func:`.switch_detection.jump_windows`): there a jump between an
    input's bounds was located from the bounds and has a mesh point within its bracket; the states'
    estimate covers it (continuous, compared everywhere), the inputs and multipliers are left out of
    theirs there, and the record says so (``jump_windows``, and the message). ``smoothness``: ``legendre_decay(sol)``."""
    mesh, untrusted = _untrusted(sol, tol, smoothness, windows)
    if windows:
        merged = merged_windows(windows)
        record["jump_windows"] = [[float(lo), float(hi)] for lo, hi in merged]
        record["message"] += (f"{JUMPS}{len(merged)} window(s) at fractions "
                              + ", ".join(f"{lo:.5g}-{hi:.5g}" for lo, hi in merged[:4])
                              + " of the horizon: located from the bounds with a mesh point inside (the jump itself, "
                              "where the input's arcs are imposed: input_arcs), their estimate leaves these windows out "
                              "(their error there is the jump's size), the states' does not")
    bad = np.flatnonzero(untrusted)
    if not len(bad):
        return
    record["nonsmooth_intervals"] = [[float(mesh[k]), float(mesh[k + 1])] for k in bad]
    spots = ", ".join(f"{mesh[k]:.6g}-{mesh[k + 1]:.6g}" for k in bad[:4])     # 4 digits read "0.398-0.398"
    record.update(met=False, message=record["message"] + (
        f"{UNTRUSTED[record['message'].startswith('estimated')]}the inputs "
        f"or multipliers are not smooth on {len(bad)} interval(s), at fractions {spots} "
        f"of the horizon (a switch inside: their Legendre coefficients fall as slowly as a "
        f"step's, up to {smoothness[0][bad].max():.2f} of it); a higher degree resolves a jump no better, so the "
        f"estimate is no upper bound there. {_advice(sol)}"))


def _advice(sol) -> str:
    """What to do about a jump the refinement cannot resolve. A mesh point helps only at the switch's true time, which
    the refinement's located one need not be: an input no effort term holds (an L1 cost, a least time) is held to its
    bounds by the barrier alone next to its switch, and the NLP trades the switch's time against barrier-sized values
    there at almost no cost (a twelfth newcomer's minimum-fuel slider: located 1.5e-6 s and 2e-5 s off the closed
    form's, and 1e-6 was still not met with mesh points there; with mesh points at the true ones, met on the first
    mesh). With a small effort term the input leaves its bounds continuously and its arcs are imposed with their
    junction times solved for (that slider with 1e-3 (up^2 + um^2): 1e-4 to 1e-7 met in 0.6-1.0 s)."""
    tr = sol.transcription
    pr = getattr(tr, "user_problem", getattr(tr, "problem", None))
    bare = sorted(set(pr.model.inputs) - penalized_inputs(sol)) if pr is not None else []
    advice = ("Put a mesh point at the switch (Radau(mesh=...)) where you know its time closer than the tolerance "
              "needs; the times located (mesh_refinement['switches_located']) are the NLP's and can be further off")
    if bare:
        names = ", ".join(f"'{n}'" for n in bare[:4])
        advice += (f". Or give {names}, which no effort term holds, a small one (problem.minimize_effort([{names}], "
                   f"weight=...)): the input then leaves its bounds continuously and its switches become junctions "
                   f"whose times are solved for; it is a nearby problem, its optimum moves with the weight")
    return advice + "; or accept the error near it"


def nonsmooth_splits(sol, tol: float, smoothness: tuple, windows=()) -> dict[int, list[float]]:
    """Where the estimate is met but not trusted (:func:`flag_nonsmooth`: inputs or multipliers not
    smooth, their last Legendre term above ``tol``, outside the jump ``windows``): each such interval
    halved, for :func:`refine`. No bound located a switch there, so the middle; the next solution says
    whether a polynomial follows each half (rolling-disk drive at 1e-3: the first interval, its friction
    cone active up to a mesh point, decay 0.50 of a step's at degree 3). ``smoothness``: ``legendre_decay(sol)``."""
    mesh, untrusted = _untrusted(sol, tol, smoothness, windows)
    return {int(k): [float((mesh[k] + mesh[k + 1]) / 2)] for k in np.flatnonzero(untrusted)
            if mesh[k + 1] - mesh[k] > 2 * MIN_INTERVAL}


def judged_smoothness(smoothness: tuple, switches) -> tuple[np.ndarray, np.ndarray]:
    """``smoothness`` (:func:`.legendre_decay.legendre_decay`) with the decay of every interval that holds a located,
    floored kink set to 0: there the inputs and multipliers kink by construction, and their estimate already carries
    the kink's own size (:func:`.junction_floors.kink_floor`), so the interval is neither flagged nor halved for it.
    Halving it only moved the kink into a shorter interval that was still "not smooth": the newcomer cart-pole at 1e-3,
    its hinge force's junction at 0.3466 of the horizon, was halved down to 5e-4 of it and "met" withdrawn after 10
    refinements, with the estimate (kink floor included) met at 1,240 points."""
    decay, tail = smoothness
    kinks = [w.interval for w in floored_kinks(switches)]
    if not kinks:
        return smoothness
    decay = np.array(decay, float)
    decay[kinks] = 0.0
    return decay, tail
