"""Optimal control of constrained rigid bodies: the problem, knowing no solver.

Declare on a model the horizon, the objective, bounds, boundary conditions and path
constraints (on coordinates, speeds, inputs and constraint loads), then
``solve(Radau(50, degree=3))``. Quantities are addressed by name: coordinates
(``rod.psi``), coordinate rates (``rod.psi_dot``), speeds (``rod.omega_z``), inputs
(``motor``), and multipliers via :meth:`OptimalControlProblem.multiplier`.

The transcription (see :mod:`ocp_constraints.ocp.transcription`) keeps the constraints
without drift: position-level forms ``phi = 0`` and velocity-level constraints
``G u + e = 0`` hold at every collocation point, with the kinematic slack of Posa et
al. (2016) that keeps the discretized system consistent.
"""
from __future__ import annotations

import time

from dataclasses import dataclass, field
from typing import Callable

import casadi as ca
import numpy as np

from .compiled_elements import check_policy
from .terms import IntegralTerm, PathConstraint, TerminalTerm, finite as _finite, reference_expression
from .solver_threads import one_blas_thread
from .schemes import Scheme
from ..mechanics.equations import SystemEquations
from ..errors import ModelError
from ..mechanics.model import Model

COORDINATES = ("auto", "maximal", "joint", "condensed")


@dataclass
class OptimalControlProblem:
    """A direct optimal-control problem on a model (problem only; no solver inside).

    Parameters
    ----------
    model
        Bodies, constraints, loads and inputs (the controls).
    t_final
        Fixed horizon (s), or the initial guess of a free one.
    t_final_bounds
        ``(lower, upper)`` makes the final time a decision variable.
    coordinates
        ``"maximal"``: every body's coordinates and speeds, every constraint with its
        multiplier. ``"joint"``: bodies on library joints (revolute, prismatic, weld) placed by
        their joint coordinates, whose constraints then hold identically and leave the NLP
        (:mod:`~ocp_constraints.ocp.joint_transcription`, paper sec. 5); names, loads and
        results stay those of the bodies. ``"auto"`` (default): joint coordinates where some
        body hangs on such a joint and no closed chain of them exists
        (:func:`~ocp_constraints.mechanics.generalized.joint_coordinates_pay`), else maximal;
        :attr:`nlp_coordinates` says which. ``"condensed"``: the maximal coordinates with the
        accelerations and multipliers solved from each point's KKT system instead of NLP variables,
        slacks only at mesh points (:mod:`~ocp_constraints.ocp.condensed_transcription`).
    compiled
        Whether the NLP's element functions run as machine code (the system C compiler, cached on
        disk by content): ``"auto"`` (default) once the time they would have saved in this problem's
        solves so far and in this one exceeds their compile time, or where a copy is cached already;
        ``"always"``; ``"never"`` (CasADi's virtual machine) (:mod:`~ocp_constraints.ocp.compiled_elements`).
    """

    model: Model
    t_final: float = 1.0
    t_final_bounds: tuple[float, float] | None = None
    integral_terms: list[IntegralTerm] = field(default_factory=list)
    terminal_terms: list[TerminalTerm] = field(default_factory=list)
    path_constraints: list[PathConstraint] = field(default_factory=list)
    time_weight: float = 0.0
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    initial_values: dict[str, float] = field(default_factory=dict)
    final_values: dict[str, float] = field(default_factory=dict)
    guess: dict[str, Callable[[np.ndarray], np.ndarray]] = field(default_factory=dict)
    coordinates: str = "auto"
    compiled: str = "auto"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.t_final) and self.t_final > 0):
            raise ModelError(f"t_final must be a positive number of seconds, got {self.t_final!r}")
        if self.coordinates not in COORDINATES:
            raise ModelError(f"coordinates must be one of {', '.join(COORDINATES)}, got {self.coordinates!r}")
        check_policy(self.compiled)
        self.eqs = SystemEquations(self.model)
        self.lam = ca.SX.sym("lam", self.eqs.nc)
        e = self.eqs
        self._named: dict[str, ca.SX] = {}
        for i, n in enumerate(self.model.coordinate_names):
            self._named[n] = e.q[i]
            self._named[f"{n}_dot"] = e.qdot[i]
        for i, n in enumerate(self.model.speed_names):
            self._named[n] = e.u[i]
        for i, n in enumerate(self.model.inputs):
            self._named[n] = e.inputs[i]
        self._model_contents = _model_contents(self.model)
        self.free_initial_values: set[str] = set()

    # -- names ------------------------------------------------------------------------
    def quantity(self, name: str) -> ca.SX:
        """A named coordinate, rate, speed or input as an expression."""
        if name not in self._named:
            import difflib

            close = difflib.get_close_matches(str(name), list(self._named), n=5, cutoff=0.6)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            # All 18 names per body (70 for a four-body model) hid the answer in the old message.
            raise ModelError(f"no quantity named '{name}' in model '{self.model.name}'{hint} Quantities are "
                             f"'<body>.<coordinate>' ({', '.join(self.model.coordinate_names[:6])}, ...), their "
                             f"rates '<body>.<coordinate>_dot', speeds ('<body>.vbar_x', '<body>.omega_z', ...) "
                             f"and inputs {list(self.model.inputs)}; bodies: {list(self.model.bodies)}")
        return self._named[name]

    def multiplier(self, constraint: str) -> ca.SX:
        """The multiplier ``lambda`` of a scalar constraint, for objectives and path constraints."""
        names = self.eqs.constraint_names
        if constraint not in names:
            raise ModelError(f"no constraint '{constraint}'; constraints: {names}")
        return self.lam[names.index(constraint)]

    def joint_force(self, channel: str) -> ca.SX:
        """``F_c`` of a joint load channel (fixed basis) as an expression of the multipliers."""
        names = [ch.prefix for ch in self.eqs.load_channels]
        if channel not in names:
            raise ModelError(f"no joint load '{channel}'; joint loads: {names}")
        return self.eqs.joint_load_expressions(self.lam)[names.index(channel)]["F"]

    # -- objective -----------------------------------------------------------------------
    def minimize_integral(self, expression, weight: float = 1.0, label: str = "integral") -> None:
        """Add ``weight * int expression dt`` (expression of q, u, inputs, lambda, t)."""
        self.integral_terms.append(IntegralTerm(label, ca.SX(expression), _finite(weight, f"weight of the objective term '{label}'")))

    def minimize_terminal(self, expression, weight: float = 1.0, label: str = "terminal") -> None:
        """Add ``weight * expression`` at the final time (a Mayer term; expression of q, u, inputs and t, where
        t is the final time), e.g. ``w * (problem.quantity("block.x") - D) ** 2`` for a target reached as
        closely as the effort allows; adds like every ``minimize_*`` term (``terminal_terms`` lists them)."""
        expression = ca.SX(expression)
        if ca.depends_on(expression, self.lam):
            raise ModelError(f"terminal term '{label}': it uses multipliers (constraint loads); a terminal term is of "
                             f"coordinates, speeds, inputs and the final time; for a load use minimize_integral or "
                             f"subject_to")
        self.terminal_terms.append(TerminalTerm(label, expression, _finite(weight, f"weight of the terminal term '{label}'")))

    def minimize_effort(self, inputs: list[str] | None = None, weight: float = 1.0) -> None:
        """Add ``weight * int sum tau_i^2 dt`` over the named inputs (default: all) to the objective; like every
        ``minimize_*`` term it adds to what is there (a second call doubles the weight; ``integral_terms`` lists them)."""
        names = list(self.model.inputs) if inputs is None else ([inputs] if isinstance(inputs, str) else list(inputs))
        if not names:
            raise ModelError(f"model '{self.model.name}' has no inputs to minimize")
        others = [n for n in names if n not in self.model.inputs]
        if others:      # a coordinate or speed here was silently int x^2 dt: minimize_integral says that on purpose
            self.quantity(others[0])        # a misspelt name: the closest names
            raise ModelError(f"minimize_effort: {others} are not inputs (the model's inputs: {list(self.model.inputs)}); "
                             f"for int x^2 dt of another quantity use minimize_integral(problem.quantity(name) ** 2)")
        self.minimize_integral(sum(self.quantity(n) ** 2 for n in names), weight, "effort")

    def minimize_load_effort(self, constraints: list[str], weights: list[float] | None = None) -> None:
        """Add ``int sum_k w_k lambda_k^2 dt`` over the named scalar constraints (``model.describe()`` lists them, e.g.
        ``"elbow.v1"``: a joint's force component along a fixed axis, N, or its moment component, N m; ``lambda`` of
        eq. 26), weights ``w_k`` default 1 (per N^2 s or (N m)^2 s). The components' signs do not matter (squared).
        For a joint's whole force vector use ``minimize_integral`` of ``|joint_force(channel)|^2``."""
        w = [1.0] * len(constraints) if weights is None else weights
        self.minimize_integral(sum(wi * self.multiplier(c) ** 2 for c, wi in zip(constraints, w)), 1.0, "load_effort")

    def minimize_final_time(self, weight: float = 1.0) -> None:
        """Add ``weight * T`` (s) to the objective; needs a free final time (``t_final_bounds``); adds like every
        ``minimize_*`` term."""
        if self.t_final_bounds is None:
            raise ModelError("minimize_final_time needs a free final time (t_final_bounds)")
        self.time_weight += _finite(weight, "weight of the final time")

    def track(self, name: str, reference: Callable, weight: float = 1.0) -> None:
        """``weight * int (quantity - reference(t))^2 dt``; ``reference`` takes a CasADi time (for samples:
        ``lambda t: ca.pw_lin(t, ca.DM(times), ca.DM(values))``)."""
        quantity = self.quantity(name)
        self.minimize_integral((quantity - reference_expression(reference, self.eqs.t, name)) ** 2, weight,
                               f"track {name}")

    # -- constraints -------------------------------------------------------------------------
    def bound(self, name: str, lower: float = -np.inf, upper: float = np.inf) -> None:
        """Bounds on a coordinate, speed or input at every point (rates go to path constraints)."""
        self.quantity(name)
        if name not in (*self.model.coordinate_names, *self.model.speed_names, *self.model.inputs):
            # Refused here, not at solve: a rate's bound used to pass until the transcription refused it.
            raise ModelError(f"bound on '{name}': only coordinates, speeds and inputs take bounds, and '{name}' is a "
                             f"rate; bound it as a path constraint: problem.subject_to(problem.quantity('{name}'), "
                             f"{lower}, {upper}, '{name} limit')")
        lower, upper = float(lower), float(upper)
        if lower > upper:
            raise ModelError(f"bound on '{name}': lower {lower} exceeds upper {upper}; swap them if they are reversed")
        # NaN, or an infinite bound on the wrong side, reached IPOPT as a raw "Ill-posed problem detected: LBX[63]"
        if np.isnan(lower) or np.isnan(upper) or lower == np.inf or upper == -np.inf:
            raise ModelError(f"bound on '{name}': got lower {lower}, upper {upper}; a bound is a number, or -inf "
                             f"(lower) / inf (upper) for no bound on that side")
        self.bounds[name] = (lower, upper)

    def subject_to(self, expression, lower: float = -np.inf, upper: float = np.inf, label: str = "path",
                   scale: float = 1.0) -> None:
        """Path constraint ``lower <= expression <= upper`` at every point. ``scale``: the expression's typical
        magnitude, if larger than its bounds say (the NLP's row is divided by the larger; values stay in your units)."""
        lower, upper = float(lower), float(upper)
        if not (np.isfinite(scale) and scale > 0):
            raise ModelError(f"path constraint '{label}': scale must be a positive number (the expression's typical "
                             f"magnitude), got {scale!r}")
        # IPOPT refuses these with a bare assertion on 'LBG[k]', which names no constraint.
        if np.isnan(lower) or np.isnan(upper) or lower > upper or lower == np.inf or upper == -np.inf:
            raise ModelError(f"path constraint '{label}': bounds must satisfy lower <= upper with lower < inf and "
                             f"upper > -inf, got lower {lower}, upper {upper}; swap them if they are reversed")
        self.path_constraints.append(PathConstraint(label, ca.SX(expression), lower, upper, float(scale)))

    def friction_cone(self, channel: str, mu: float, normal=(0.0, 0.0, 1.0)) -> None:
        """``N = F . n >= 0`` and ``|F - N n|^2 <= mu^2 N^2`` for a contact's load ``F`` (``mu`` >= 0, no unit)."""
        if not (np.isfinite(mu) and mu >= 0):
            raise ModelError(f"friction_cone('{channel}'): the friction coefficient mu must be a finite number >= 0, "
                             f"got {mu!r}")
        normal = np.asarray(normal, dtype=float).reshape(-1)
        if normal.shape != (3,) or not np.all(np.isfinite(normal)) or not np.linalg.norm(normal) > 0:
            raise ModelError(f"friction_cone('{channel}'): normal must be 3 finite numbers, not all zero (fixed "
                             f"basis), got {normal.tolist()}")
        n = ca.DM(normal / np.linalg.norm(normal))
        F = self.joint_force(channel)
        N = ca.dot(F, n)
        Ft = F - N * n
        # The rows' typical magnitudes as their scales, since their bounds (0) say nothing: N ~ the model's weight W,
        # and the cone row ~ (mu W)^2, the size of the friction it allows. Unscaled, a heavy body's cone in N^2 left
        # IPOPT creeping (the newcomer wheel at 200 kg: 124 iterations); scaled by W^2, 1/mu^2 too much, the cone
        # counted so little that fine meshes of the rolling disk's drive wandered to other optima (J 0.216, 0.517
        # for 0.1765).
        load = max(1.0, sum(b.mass for b in self.model.bodies.values()) * float(np.linalg.norm(self.model.gravity)))
        self.subject_to(N, 0.0, np.inf, f"{channel} normal force", scale=load)
        cone = (mu * load) ** 2 if mu > 0 else load**2
        self.subject_to(ca.dot(Ft, Ft) - mu**2 * N**2, -np.inf, 0.0, f"{channel} friction cone", scale=cone)

    def initial(self, values: dict[str, float]) -> None:
        """Values at ``t = 0`` of named coordinates, rates, speeds or inputs."""
        for k in values:
            self.quantity(k)
        self.initial_values.update({k: float(v) for k, v in values.items()})

    def final(self, values: dict[str, float]) -> None:
        """Values at the final time."""
        for k in values:
            self.quantity(k)
        self.final_values.update({k: float(v) for k, v in values.items()})

    def set_guess(self, name: str, values: Callable[[np.ndarray], np.ndarray]) -> None:
        """Initial guess of a coordinate, speed or input as a function of time (array in, array out)."""
        self.quantity(name)
        self.guess[name] = values

    def leave_free(self, names: list[str]) -> None:
        """Declare initial values the optimizer is meant to choose (coordinates or speeds that no
        constraint and no :meth:`initial` value fixes): the pre-solve check then accepts them."""
        for n in names:
            self.quantity(n)
        self.free_initial_values.update(names)

    # -- solving -------------------------------------------------------------------------------
    def structure_key(self) -> tuple:
        """Everything a transcription builds into its NLP: objective terms and weights, path
        constraints and their bounds, which values are fixed at the ends, the horizon. Two solves
        with the same key may share a transcription; bounds, boundary *values* and guesses are
        read afresh at every solve."""
        if _model_contents(self.model) != self._model_contents:
            raise ModelError(f"model '{self.model.name}' changed after this OptimalControlProblem was created "
                             f"(bodies, constraints, loads or inputs added); create the problem after the model "
                             f"is complete")
        return (tuple((id(term.expression), term.weight) for term in self.integral_terms),
                tuple((id(term.expression), term.weight) for term in self.terminal_terms),
                tuple((id(c.expression), c.lower, c.upper, c.scale) for c in self.path_constraints),
                self.time_weight, tuple(self.initial_values), tuple(self.final_values),
                self.t_final_bounds is not None, None if self.t_final_bounds is not None else self.t_final,
                # In joint coordinates a bound on a body coordinate or speed is a path row of the NLP.
                self.coordinates, check_policy(self.compiled), () if self.nlp_coordinates == "maximal" else tuple(sorted(
                    (n, b) for n, b in self.bounds.items() if n not in self.model.inputs)))

    @one_blas_thread
    def solve(self, method=None, ipopt_options: dict | None = None, warm_start=None, *, check: bool = True,
              progress: bool | None = None, starts: int = 1, seed: int = 0, client=None,
              tolerance: float | None = None, max_refinements: int | None = None):
        """Transcribe with ``method`` (a :mod:`~ocp_constraints.ocp.schemes` scheme) and solve with IPOPT.

        Before IPOPT starts, :func:`~ocp_constraints.ocp.diagnostics.check_problem` looks for what
        would make it fail or wander (undetermined initial values, boundary values off the
        constraints, reversed bounds, bad guesses, an NLP larger than the memory) and raises a
        :class:`~ocp_constraints.errors.ModelError` naming it; ``check=False`` skips that.
        The transcription is built once per method and problem structure (:meth:`structure_key`)
        and reused by later solves; any edit of the objective or the path constraints builds it anew.
        ``warm_start``: a solution of this problem to start from, on the same or another
        mesh or scheme (e.g. a coarse solve before a fine one).
        ``progress``: print IPOPT's progress (iteration, objective, infeasibility, elapsed) to the
        terminal; default: when the solve takes longer than a few seconds and stderr is a terminal.
        Ctrl-C stops IPOPT cleanly at the next iteration and keeps the last iterate.
        Returns an :class:`~ocp_constraints.ocp.solution.OCPSolution`; a failed or interrupted solve
        raises :class:`~ocp_constraints.errors.OCPSolveError` carrying the last iterate.
        ``starts`` > 1: multi-start from perturbed guesses drawn with ``seed``, the best local optimum
        kept and the spread of the others in ``sol.starts``, ``sol.local_optima``, ``sol.multistart``;
        with a Dask ``client`` the starts run on its workers
        (:func:`~ocp_constraints.ocp.multistart.solve_multistart`).
        ``tolerance``: the error you accept (states in SI units, multipliers relative to the largest
        load); hp mesh refinement from ``method`` (a Radau mesh, default 10 intervals of degree 5)
        until the a-posteriori estimate meets it, the final mesh, the estimate per quantity and the
        history in ``sol.mesh_refinement`` (:func:`~ocp_constraints.ocp.mesh_refinement.solve_to_tolerance`);
        ``max_refinements``: how many refinements at most (default
        :data:`~ocp_constraints.ocp.mesh_refinement.MAX_REFINEMENTS`).
        """
        if method is not None and not isinstance(method, Scheme):
            raise ModelError(f"method must be a scheme such as oc.Radau(50, degree=3), oc.HermiteSimpson(50) or "
                             f"oc.Trapezoidal(50), got {method!r}")
        if max_refinements is not None and tolerance is None:
            raise ModelError("max_refinements applies to solve(tolerance=...) only")
        if tolerance is not None:
            from .diagnostics import check_problem
            from .mesh_refinement import check_max_refinements, check_tolerance, solve_to_tolerance, start_scheme

            started = (time.perf_counter(), time.process_time())    # the totals count the checks too

            tolerance = check_tolerance(tolerance)
            if not (self.integral_terms or self.terminal_terms or self.time_weight):
                raise ModelError(f"solve(tolerance=...) needs an objective: '{self.model.name}' has none, so every motion "
                                 f"that meets its constraints is a solution and no mesh converges to one; add one "
                                 f"(minimize_effort, minimize_integral, minimize_terminal, minimize_final_time, track), or "
                                 f"solve on a fixed mesh, solve(oc.Radau(N, degree=p)), for a feasible motion")
            if starts != 1:
                raise ModelError("starts > 1 and tolerance are not combined: refine the best start's solution by "
                                 "passing it as warm_start with tolerance=...")
            self.structure_key()
            if check:
                check_problem(self, start_scheme(method, self))
            limit = {} if max_refinements is None else {"max_refinements": check_max_refinements(max_refinements)}
            return solve_to_tolerance(self, tolerance, method, ipopt_options, warm_start, progress=progress,
                                      started=started, **limit)
        if method is None:
            raise ModelError("solve needs a method (e.g. Radau(50, degree=3)) or a tolerance (e.g. tolerance=1e-6)")
        if starts != 1:
            from .multistart import solve_multistart

            return solve_multistart(self, method, starts, seed, client, ipopt_options, warm_start, check=check,
                                    progress=progress)
        from .diagnostics import check_problem

        self.structure_key()               # a model edited after the problem is refused before any check
        if check:
            check_problem(self, method)
        return self.transcription(method).solve(ipopt_options or {}, warm_start, progress=progress)

    @property
    def nlp_coordinates(self) -> str:
        """``"joint"`` or ``"maximal"``: the coordinates the NLP is written in (``coordinates``
        with ``"auto"`` decided for this model)."""
        if self.coordinates != "auto":
            return self.coordinates
        from ..mechanics.generalized import joint_coordinates_pay

        key = _model_contents(self.model)
        cached = self.__dict__.get("_auto_coordinates")
        if cached is None or cached[0] != key:
            cached = (key, "joint" if joint_coordinates_pay(self.eqs) else "maximal")
            self.__dict__["_auto_coordinates"] = cached
        return cached[1]

    def transcription(self, method, *, cache: bool = True):
        """The NLP of this problem with ``method``, built once per method and :meth:`structure_key`;
        ``cache=False`` builds it without keeping it (mesh refinement: each mesh is solved once)."""
        from .transcription import transcribe

        if self.coordinates not in COORDINATES:
            raise ModelError(f"coordinates must be one of {', '.join(COORDINATES)}, got {self.coordinates!r}")
        check_policy(self.compiled)
        if self.nlp_coordinates == "joint":
            from .joint_transcription import transcribe_joint as transcribe
        elif self.nlp_coordinates == "condensed":
            from .condensed_transcription import transcribe_condensed as transcribe

        key = (method.label, method.intervals, None if method.mesh is None else tuple(method.mesh),
               (getattr(method, "degrees", None), method.free_points), self.structure_key())
        cache = self.__dict__.setdefault("_transcriptions", {}) if cache else {}
        if key not in cache:
            for old in [k for k in cache if k[:4] == key[:4]]:
                del cache[old]     # the problem changed: its old NLP for this method is of no use
            try:
                cache[key] = transcribe(self, method)
            except ModelError:
                if self.coordinates != "auto" or self.nlp_coordinates != "joint":
                    raise
                # "auto" chose joint coordinates but this model cannot be written in them (e.g. Euler
                # angles singular at the joint coordinates' zero): the maximal form, as the user
                # asked for no particular one; a real error in the problem is raised there too.
                from .transcription import transcribe as transcribe_maximal

                self.__dict__["_auto_coordinates"] = (_model_contents(self.model), "maximal")
                key = key[:4] + (self.structure_key(),)
                cache[key] = transcribe_maximal(self, method)
        return cache[key]


def _model_contents(model: Model) -> tuple:
    """What the equations were built from: names of bodies, constraints, loads and inputs."""
    return (tuple(model.bodies), tuple(c.name for c in model.constraints), tuple(f.name for f in model.forces),
            tuple(t.name for t in model.torques), tuple(model.inputs))
