"""The objective's scale in the warm solves of a mesh refinement (:mod:`.mesh_refinement`): IPOPT's
``obj_scaling_factor`` chosen so that the objective's largest curvature at the start is 1.

Why. An integral objective is a quadrature, ``sum_i w_i L(x_i, u_i)``: its second derivative in a point's
variables carries that point's weight ``w_i``, a fraction of its interval's length. A refinement shortens the
intervals, so the Lagrangian's Hessian shrinks with them while the constraint Jacobian does not, and the
reduced Hessian of a fine mesh falls below the regularization IPOPT adds when its inertia test fails. Then
IPOPT crawls: a newcomer's slider-crank (a closed loop, least ``int tau^2``, T = 0.5 s) on Radau 7 with
20 intervals had reduced-Hessian eigenvalues 1e-9 to 2e-6 at its optimum, IPOPT regularized every iteration
(``lg(rg)`` about -7) and took 143 iterations (205 in maximal coordinates, 128 s of CPU; 40 intervals: past
400); its refinement to 1e-4 stalled after 58 s with its estimate rising from 1.2e-4 to 7.6e-3.

IPOPT scales the objective *down* by itself where its gradient exceeds 100 (``nlp_scaling_max_gradient``),
never up. Here it is scaled up: by ``1 / max_i |d^2 f / d z_i^2|`` at the start, no further than a gradient of
:data:`MAX_GRADIENT` (IPOPT's own ceiling; an objective linear in some variable, a final time, has a gradient but
little curvature), and never below 1. Only the warm solves from the refinement's first resolved estimate on, which
start at an optimum of a mesh close to theirs. From a problem's rough guess a scaled objective took some of our
problems to other local optima (``scripts/ocp_default_robustness.py --candidate obj_scaling=1e2 obj_scaling=curvature``:
the newcomer arm 14.68 for 10.40 on Radau 3 N = 20; with this rule 7 of 36 runs elsewhere, 2 of them worse), and so
did a warm solve from an unresolved mesh, a cold solve in all but name (the suite's cart double pendulum's pilot:
629 iterations to J = 2,778 for 162.4); ``results/bench/refinement_objective_scaling/``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

OPTION = "ipopt.obj_scaling_factor"
# An objective smaller than this at an optimum (after scaling) is brought up to 1 (small_objective_scale), unless
# it fell there from REACHED_ZERO times its start or less: a target reached exactly, nothing to resolve.
SMALL = 1e-2
REACHED_ZERO = 1e-12
# IPOPT's own ceiling on a scaled gradient (nlp_scaling_max_gradient's default): the scaled objective's gradient
# at the start is kept below it.
MAX_GRADIENT = 100.0


def objective_scale(block, x0: np.ndarray) -> float:
    """The factor for IPOPT's ``obj_scaling_factor`` at the start ``x0`` of the NLP ``block`` (a
    :class:`.nlp_assembly.BlockNLP`): ``1 / max |diag Hessian of f|``, at most ``MAX_GRADIENT / max |grad f|``,
    at least 1 (module notes); 1 where the objective has no curvature."""
    hessian = block.hess_lag(x0, [], 1.0, np.zeros(block.m))     # the Lagrangian's, every multiplier zero
    top = float(np.abs(np.asarray(ca.DM(ca.diag(hessian)))).max(initial=0.0))
    if not np.isfinite(top) or top <= 0.0:
        return 1.0
    scale = 1.0 / top
    gradient = float(np.abs(np.asarray(block.grad_f(x0, [])[1])).max(initial=0.0))
    if np.isfinite(gradient) and gradient > 0.0:
        scale = min(scale, MAX_GRADIENT / gradient)
    return max(1.0, scale)



def small_objective_scale(objective: float, scale: float = 1.0, start=None) -> float | None:
    """The ``obj_scaling_factor`` that brings an objective of ``objective`` (unscaled, at or near an optimum) seen
    through ``scale`` up to 1 where it is smaller than :data:`SMALL`; None where it is not, where it is 0, or, given
    ``start`` (a function giving the objective at the solve's start, from the problem's guess; called only where
    the objective is small), where that was 0 or the solve drove the
    objective to :data:`REACHED_ZERO` of it or less: a target reached exactly, zero up to rounding, however small
    its units (a terminal target that the guess already reached starts at 0). ``start`` None: the solve starts at an
    optimum whose objective was found too small before (its warm solves), scaled whenever it is small.

    Why. IPOPT's tolerances are absolute: it stops where the dual infeasibility is below ``tol`` (1e-10), and that
    infeasibility is of the size of the objective's gradient, which scales with the objective. IPOPT scales a large
    objective down by itself (:data:`MAX_GRADIENT`), never a small one up. A problem in small units then stops at
    the first feasible point and reports "optimal": a rod of 1 cm and 1 g swung up in 0.5 s (objective 6e-10
    N^2 m^2 s), solved in 5 iterations to an objective 12x its optimum's, or the swing-up with its effort weighted
    1e-12 (the weight must not change the optimum: the torque came out 4.1 N m off; with 1e-8, 2.3e-3 N m off).
    The same problems with the objective brought to 1 match the well-scaled ones to 1e-9
    (``tests/test_ocp_objective_units.py``; a rod of 100 um and 1 ug, objective 9e-22, too). No problem of the suite or
    the examples comes near: their optima's objectives are 0.057 and more, so they are solved as before."""
    size = abs(float(objective))
    if not np.isfinite(size * scale) or size * scale >= SMALL or size == 0.0:
        return None
    if start is not None:
        begun = abs(float(start()))
        if begun == 0.0 or size <= REACHED_ZERO * begun:
            return None
    return 1.0 / size
