"""Times at which a problem's own expressions kink or jump, and the refinement's first mesh with a mesh point at each.

A reference tracked from samples (``ca.pw_lin(t, times, values)``), a force switched on at a given time
(``ca.if_else(t < 0.5, 0, F)``) or a profile with ``fabs``, ``fmin`` or ``fmax`` of the time makes the solution's
inputs and multipliers kink there. Inside a collocation interval a kink costs accuracy that only shorter intervals
buy back, slowly (:mod:`.junction_floors`, ``KINK_C``); at a mesh point it costs nothing. These times are in the
expressions: each is where an affine function of ``t`` is compared with another (``<``, ``<=``, ``==``, ``!=``,
``fmin``, ``fmax``) or passes zero under ``fabs`` or ``sign``. Found by reading the expressions' operations, not
by sampling. Measured (a ninth newcomer's rod tracking samples of a sine at 50 Hz by ``np.interp``, whose CasADi form
is such comparisons; ``results/bench/refinement_newcomer9.md``): from the default first mesh, 1e-6 was not met on
1,751 points; from 100 intervals with a mesh point at every sample, met on the first mesh (501 points, 0.3 s) with
a true error of 2e-9.

Where breakpoints were added, the refinement's solves turn MUMPS's own scaling off (``ipopt.mumps_scaling`` 0, as
:func:`.mesh_solves.without_mumps_scaling` does where a bound is reached): a block tracking 101 samples over 1 s
spent minutes in one factorization of its pilot (Radau 200 x 7) with it, and meets 1e-6 on 501 points in 1.3 s
without it (``python scripts/refinement_time_breakpoints.py --tolerances 1e-6 --samples 101``).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .schemes import Radau

# Operations of two arguments whose result kinks or jumps where the arguments are equal, and of one argument where
# it passes zero. Floor and ceil (a jump at every integer) are left out.
_CROSSING = {ca.OP_LT, ca.OP_LE, ca.OP_EQ, ca.OP_NE, ca.OP_FMIN, ca.OP_FMAX}
_ZERO = {ca.OP_FABS, ca.OP_SIGN}


def breakpoint_times(expressions, t: ca.SX) -> np.ndarray:
    """The times (s, sorted, unique to 1e-12 s) where ``expressions`` (CasADi SX of ``t`` and other symbols) kink or
    jump as functions of the explicit time ``t`` (module notes)."""
    parts = [ca.vec(ca.SX(e)) for e in expressions if ca.SX(e).numel()]
    expr = ca.vertcat(*parts) if parts else ca.SX(0, 1)
    if not expr.numel() or not ca.depends_on(expr, t):
        return np.zeros(0)
    others = [s for s in ca.symvar(expr) if not ca.is_equal(s, t)]
    f = ca.Function("breakpoints", [t, ca.vertcat(*others) if others else ca.SX(0, 1)], [expr])
    affine: dict[int, tuple[float, float] | None] = {}      # work slot -> (a, b) of a t + b, or None
    found = []
    for k in range(f.n_instructions()):
        op, args, out = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_OUTPUT:
            continue
        x = [affine.get(i) for i in args] if op != ca.OP_INPUT else []
        value = None
        if op == ca.OP_INPUT:
            value = (1.0, 0.0) if args[0] == 0 else None
        elif op == ca.OP_CONST:
            value = (0.0, float(f.instruction_constant(k)))
        elif None in x:
            value = None
        elif op in _CROSSING and len(x) == 2 and x[0][0] != x[1][0]:
            found.append((x[1][1] - x[0][1]) / (x[0][0] - x[1][0]))
        elif op in _ZERO and x[0][0] != 0.0:
            found.append(-x[0][1] / x[0][0])
        else:
            value = _affine(op, x)
        affine[out[0]] = value
    times = np.unique(np.round(np.asarray(found, float), 12))
    return times[np.isfinite(times)]


def _affine(op: int, x: list) -> tuple[float, float] | None:
    """The affine form of an operation's result on affine arguments, or None where it is not affine."""
    if op == ca.OP_ADD:
        return x[0][0] + x[1][0], x[0][1] + x[1][1]
    if op == ca.OP_SUB:
        return x[0][0] - x[1][0], x[0][1] - x[1][1]
    if op == ca.OP_NEG:
        return -x[0][0], -x[0][1]
    if op == ca.OP_TWICE:
        return 2 * x[0][0], 2 * x[0][1]
    if op == ca.OP_MUL and (x[0][0] == 0.0 or x[1][0] == 0.0):
        c, v = (x[0][1], x[1]) if x[0][0] == 0.0 else (x[1][1], x[0])
        return c * v[0], c * v[1]
    if op == ca.OP_DIV and x[1][0] == 0.0 and x[1][1] != 0.0:
        return x[0][0] / x[1][1], x[0][1] / x[1][1]
    if op == ca.OP_ASSIGN:
        return x[0]
    return None


def problem_breakpoints(problem) -> np.ndarray:
    """The breakpoints of a fixed-horizon problem's expressions of time inside its horizon (s): its objective's
    integrands, path constraints, applied forces and constraints' explicit time terms. None for a free final time
    (a time in seconds is then no fixed fraction of the horizon). Kept on the problem for its structure
    (:meth:`~.problem.OptimalControlProblem.structure_key`): a solve to a tolerance asks twice, for its checks and its
    first mesh, and an edited objective or path constraint is read again."""
    if problem.t_final_bounds is not None:
        return np.zeros(0)
    key, kept = problem.structure_key(), problem.__dict__.get("_time_breakpoints")
    if kept is not None and kept[0] == key:
        return kept[1]
    e = problem.eqs
    expressions = ([term.expression for term in problem.integral_terms]
                   + [c.expression for c in problem.path_constraints] + [e.forces, e.e, e.phi])
    times = breakpoint_times(expressions, e.t)
    T = float(problem.t_final)
    times = times[(times > 1e-9 * T) & (times < (1 - 1e-9) * T)]
    problem.__dict__["_time_breakpoints"] = (key, times)
    return times


def with_breakpoints(scheme: Radau, problem) -> Radau:
    """``scheme`` with a mesh point at each of the problem's breakpoints (:func:`problem_breakpoints`): the nearest
    mesh point moved there where it is within a tenth of its interval, else the interval split there; each new
    interval keeps its parent's degree."""
    times = problem_breakpoints(problem)
    if not times.size:
        return scheme
    mesh = list(np.asarray(scheme.mesh_fractions, float))
    degrees = [scheme.interval_scheme(k).degree for k in range(scheme.intervals)]
    kept = {0.0, 1.0}       # the ends and the breakpoints placed so far: never moved
    for fraction in times / float(problem.t_final):
        k = min(int(np.searchsorted(mesh, fraction, side="right")) - 1, len(mesh) - 2)
        h = mesh[k + 1] - mesh[k]
        near = k if fraction - mesh[k] <= mesh[k + 1] - fraction else k + 1
        if abs(mesh[near] - fraction) <= 1e-12 * max(h, 1e-300):
            kept.add(mesh[near])
            continue
        if mesh[near] not in kept and abs(mesh[near] - fraction) <= 0.1 * h:
            mesh[near] = fraction
        else:
            mesh.insert(k + 1, fraction)
            degrees.insert(k + 1, degrees[k])
        kept.add(fraction)
    return Radau(len(mesh) - 1, mesh=tuple(mesh), degrees=degrees)
