"""Direct collocation of an :class:`OptimalControlProblem` into an IPOPT NLP.

Variables at every collocation point ``i`` (unique times over the mesh): states
``x_i = (q_i, u_i)``, accelerations ``a_i = u'_i``, multipliers ``lambda_i``, inputs
``w_i``, and (except at ``t_0``) the kinematic slack ``gamma_i`` of Posa et al. (2016).
The state derivative at a point is ``D = (N(q) u + phi_q^T gamma, a)`` (the coordinate
rates are expressions, not variables); constraints at every point: the implicit dynamics

    M(q) a = f(q, u, t, w) + G^T lambda,

the velocity-level constraints ``G u + e = 0`` and the position-level forms
``phi(q, t) = 0`` (with each unit quaternion's ``|q|^2 = 1``: the equations hold at any
length, :func:`~ocp_constraints.mechanics.equations.unit_lengths`). Why this choice: imposing both ``phi = 0`` and ``G u + e = 0`` makes
the solution drift-free at every point (the contract of DESIGN.md); the slack
``gamma`` absorbs the discretization's mismatch between the two (it vanishes as the
mesh is refined), so the NLP stays consistent, as in Moco. At ``t_0`` the
acceleration-level constraint ``G a + gamma_acc = 0`` determines ``lambda_0``. The
scheme's defects tie ``x`` and ``D`` (see :mod:`ocp_constraints.ocp.schemes`).
Radau defines ``h u'_j = sum_r C_rj u_r`` at its collocation points; up to degree 4
``a_j`` is that expression there, not a variable, and only the coordinate defects
remain: the same NLP with ``nu`` fewer variables and rows per point (IPOPT's
factorization is cheaper; see ``Scheme.accelerations_from_speeds``).
The NLP is a few kinds of SX elements (one point, one interval, the boundary rows)
repeated over the mesh; IPOPT gets exact derivatives assembled from each element's own
(:mod:`ocp_constraints.ocp.nlp_assembly`), so the build grows like the mesh. On an hp mesh
(``Radau(mesh=..., degrees=...)``) each interval has its own scheme: one element kind per degree.
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np

from .compiled_elements import machine_code
from .nlp_assembly import BlockNLP, derivative_cache
from .bounds import variable_bounds
from .guess import consistent_guess, from_solution
from .imposed_arcs import pin_arcs
from .interpolation import interpolation_matrix
from .layout import Layout
from .objective_scaling import OPTION as OBJECTIVE_SCALING, objective_scale, small_objective_scale
from .progress import IterationMonitor, stop_on_signals, without_pin_warning
from .solution import OCPSolution
from .solver_threads import ipopt_solver
from ..errors import ModelError, OCPSolveError
from ..mechanics.state import project_positions
from .schemes import Scheme
from .transcription_elements import ElementKinds

DEFAULT_IPOPT = {"ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 3000,
                 "ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}


class Transcription(ElementKinds):
    """The NLP of one problem and one scheme, built once, solvable many times."""

    # Arcs imposed on the bounds (.imposed_arcs.pin_arcs; set by a refinement's junction alignment)
    arcs: tuple = ()

    def __init__(self, problem, scheme: Scheme, like: Transcription | None = None):
        """``like``: a transcription of the same problem, unchanged since it was built (the meshes of one
        refinement, :mod:`.mesh_refinement`), whose point functions this one takes instead of building them."""
        started = time.perf_counter()
        self.problem, self.scheme, self._like = problem, scheme, like
        e = problem.eqs
        self.eqs = e
        nx = e.nq + e.nu
        n_in = e.inputs.numel()
        N = scheme.intervals
        # Each interval's own scheme (one for all on a uniform mesh; its degree on an hp mesh)
        # and where its points start: the last point of an interval is the first of the next.
        self.local = [scheme.interval_scheme(k) for k in range(N)]
        counts = scheme.points_per_interval
        self.offsets = np.concatenate([[0], np.cumsum(counts - 1)]).astype(int)
        P = int(self.offsets[-1] + 1)
        # Where the scheme gives u' from the speeds (Radau up to degree 4), accelerations
        # after t0 are expressions, not variables: a smaller KKT system, the same NLP.
        self.from_speeds = scheme.accelerations_from_speeds is not None
        n_acc = 1 if self.from_speeds else P
        self.layout = Layout(P, nx, e.nu, e.nc, e.position_rows.numel(), n_in, problem.t_final_bounds is not None, n_acc,
                             len(scheme.free_points) + 1 if scheme.free_points else 0)
        self.fractions, self.quadrature = self.point_times(scheme)

        owner = getattr(self, "user_problem", problem)
        self.machine_code = machine_code(owner, getattr(owner, "compiled", "auto"))
        compiling = self.machine_code.seconds
        self.block = BlockNLP(sum(self.layout.sizes()), self._elements(), derivative_cache(owner), self.machine_code)
        self.compile_time = self.machine_code.seconds - compiling      # of build_time: compiling or loading C
        self.nlp = self.block.nlp
        self._lbg, self._ubg = self.block.lbg, self.block.ubg
        self._boundary_rows = []
        for which, values in (("initial", problem.initial_values), ("final", problem.final_values)):
            for r, name in enumerate(values):
                self._boundary_rows.append((which, name, self.block.rows(which) + r))
        self._solver = None
        self._solver_options: dict | None = None
        self.build_time = time.perf_counter() - started

    def point_times(self, scheme: Scheme) -> tuple[np.ndarray, np.ndarray]:
        """Normalized time of every point on ``scheme``'s mesh, and its quadrature weight (times the horizon)."""
        mesh = scheme.mesh_fractions
        frac, quad = np.zeros(self.layout.n_points), np.zeros(self.layout.n_points)
        for k, local in enumerate(self.local):
            hk = mesh[k + 1] - mesh[k]
            points = self.interval_points(k)
            frac[points] = mesh[k] + local.tau * hk
            quad[points] += local.weights * hk
        return frac, quad

    def interval_points(self, k: int) -> range:
        """The points of interval ``k``, both ends included (the last shared with the next)."""
        return range(int(self.offsets[k]), int(self.offsets[k + 1]) + 1)

    def interpolation_matrix(self, fractions, algebraic=False, intervals=None) -> np.ndarray:
        """Point values to values at normalized times (:func:`.interpolation.interpolation_matrix`)."""
        return interpolation_matrix(self, fractions, algebraic, intervals)

    # -- bounds and guess ---------------------------------------------------------------------
    def _bounds(self, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return variable_bounds(self, x0)

    def _boundary_values(self) -> tuple[np.ndarray, np.ndarray]:
        lbg, ubg = self._lbg.copy(), self._ubg.copy()
        for which, name, row in self._boundary_rows:
            v = (self.problem.initial_values if which == "initial" else self.problem.final_values)[name]
            lbg[row] = ubg[row] = v
        for row in self._fixed_length_rows():
            lbg[row], ubg[row] = -np.inf, np.inf
        return lbg, ubg

    def _fixed_length_rows(self) -> list[int]:
        """The rows ``|q|^2 = 1`` at ``t_0`` and ``t_f`` of the quaternions whose four components are boundary
        values there (checked unit before the solve): the values hold the length, and the row again makes the
        constraint Jacobian rank-deficient. Released (no bounds), not removed: the NLP's shape stays one per
        mesh. Measured on a free-floating base with an arm (tests/test_ocp_quaternions.py), Radau 7
        N = 5: 134 IPOPT iterations with the redundant row, 16 with it released (14-16 with other ends given)."""
        e = self.eqs
        bodies = getattr(e, "unit_length_bodies", [])
        if not bodies:
            return []
        values = getattr(self, "user_problem", self.problem)
        rows = []
        for point, given in ((0, values.initial_values), (self.layout.n_points - 1, values.final_values)):
            if point not in self.position_rows_at:      # no position rows there (condensed: not a slack point)
                continue
            element, instance, first = self.position_rows_at[point]
            for k, body in enumerate(bodies):
                if all(f"{body}.q{c}" in given for c in "wxyz"):    # the length rows follow phi
                    rows.append(self.block.rows(element, instance) + first + e.phi.numel() + k)
        return rows

    def initial_guess(self) -> np.ndarray:
        """A consistent start from the user's guesses (see :mod:`.guess`): coordinates guessed or
        linear between boundary values, on the constraints; speeds, accelerations, multipliers
        and inputs that fit them."""
        X, W = self._user_guess()
        X, A, L, W = consistent_guess(self, X, W, self.problem.t_final)
        return self._pack(X, L, W, self.problem.t_final, A=A)

    def _user_guess(self) -> tuple[np.ndarray, np.ndarray]:
        """The user's guesses at every point: coordinates (else linear between boundary values) and
        speeds (NaN where none), inputs (NaN where none)."""
        pr, lay = self.problem, self.layout
        t = self.fractions * pr.t_final
        X = np.full((lay.nx, lay.n_points), np.nan)
        for r, n in enumerate(pr.model.coordinate_names + pr.model.speed_names):
            if n in pr.guess:
                X[r] = np.broadcast_to(pr.guess[n](t), t.shape)
            elif r < self.eqs.nq:
                a = pr.initial_values.get(n, pr.final_values.get(n, 0.0))
                b = pr.final_values.get(n, a)
                X[r] = a + (b - a) * self.fractions
        W = np.full((lay.n_in, lay.n_points), np.nan)
        for r, n in enumerate(pr.model.inputs):
            if n in pr.guess:
                W[r] = np.broadcast_to(pr.guess[n](t), t.shape)
        return X, W

    def guess_from(self, solution: OCPSolution) -> np.ndarray:
        """A start from a solution of this problem on another mesh or scheme (:func:`.guess.from_solution`)."""
        if getattr(solution, "transcription", None) is self:
            return np.asarray(solution.decision_vector, float)
        X, L, W = from_solution(self, solution)
        return self._pack(X, L, W, solution.t_final)

    def _pack(self, X, L, W, t_final: float, A: np.ndarray | None = None) -> np.ndarray:
        """The decision vector of these blocks, slacks zero. Without ``A``: positions projected
        onto ``phi = 0`` and accelerations from the speeds by finite differences."""
        e, lay = self.eqs, self.layout
        t = self.fractions * t_final
        if A is None:
            self._project_positions(X, W, t)
            A = np.gradient(X[e.nq :], t, axis=1) if lay.n_points > 1 else np.zeros((e.nu, 1))
        parts = [X.ravel(order="F"), A[:, : lay.n_acc].ravel(order="F"), L.ravel(order="F"), W.ravel(order="F"),
                 np.zeros(lay.nh * (lay.n_points - 1)), np.array([t_final] if lay.free_time else []),
                 np.full(lay.n_phases, t_final)]      # each phase at its nominal length
        return np.concatenate(parts)

    def _project_positions(self, X: np.ndarray, W: np.ndarray, t: np.ndarray) -> None:
        """Move the coordinates of ``X`` (in place) onto ``phi = 0`` at the points that are off it.

        A start interpolated from a converged solution is on phi = 0 to its interpolation error
        already: project only the points that are not (a point's Gauss-Newton costs ~0.5 ms, a
        warm start of an hp mesh has hundreds of points)."""
        e, P = self.eqs, X.shape[1]
        off = np.arange(P)
        if e.phi.numel():
            phi = np.asarray(self._phi_function().map(P)(X[: e.nq], t[None, :], W))
            off = np.flatnonzero(~np.all(np.abs(phi) <= 1e-12, axis=0))
        for i in off:
            X[: e.nq, i] = project_positions(e, X[: e.nq, i], t[i], inputs=W[:, i])

    def _phi_function(self) -> ca.Function:
        """``(q, t, inputs) -> phi``, the position-level constraint forms."""
        if "_phi" not in self.__dict__:
            e = self.eqs
            self._phi = ca.Function("phi", [e.q, e.t, e.inputs], [e.phi])
        return self._phi

    def accelerations(self, X: np.ndarray, A: np.ndarray, t_final: float) -> np.ndarray:
        """``u'`` at every point (``nu x P``) from the state and acceleration blocks of a
        decision vector: the variables, or from the speeds where the scheme gives them."""
        if not self.from_speeds:
            return A
        nq = self.eqs.nq
        out = np.zeros((self.eqs.nu, self.layout.n_points))
        out[:, 0] = A[:, 0]
        mesh = self.scheme.mesh_fractions
        for k, local in enumerate(self.local):
            points = list(self.interval_points(k))
            out[:, points[1:]] = X[nq:, points] @ local.derivative_matrix[:, 1:] / ((mesh[k + 1] - mesh[k]) * t_final)
        return out

    # -- solve ----------------------------------------------------------------------------------
    def completed(self, sol: OCPSolution) -> OCPSolution:
        """The solution as users query it, from the NLP's own (here the same; a transcription whose NLP
        leaves out coordinates or multipliers computes them here, also for a failed solve's last iterate)."""
        return sol

    def solve(self, ipopt_options: dict, warm_start=None, progress: bool | None = None,
              scale_objective: bool = False) -> OCPSolution:
        """Solve from ``warm_start`` (a solution) or the problem's guess. ``scale_objective``: IPOPT's
        ``obj_scaling_factor`` from the objective's curvature at the start (:mod:`.objective_scaling`; the
        refinement's warm solves), unless ``ipopt_options`` sets it."""
        opts = {**DEFAULT_IPOPT, **ipopt_options}
        x0 = self.initial_guess() if warm_start is None else self.guess_from(warm_start)
        if scale_objective and OBJECTIVE_SCALING not in ipopt_options:
            opts[OBJECTIVE_SCALING] = objective_scale(self.block, x0)
        # Started at an optimum whose objective had to be brought to 1: this one is too, now, not after the solve.
        small_units = bool(getattr(warm_start, "small_objective", False))
        if small_units and OBJECTIVE_SCALING not in ipopt_options:
            small = small_objective_scale(float(self.block.grad_f(x0, [])[0]), opts.get(OBJECTIVE_SCALING, 1.0))
            opts[OBJECTIVE_SCALING] = max(opts.get(OBJECTIVE_SCALING, 1.0), small or 0.0)
        started = time.perf_counter()
        if self._solver is None or opts != self._solver_options:
            self._monitor = IterationMonitor(self.nlp["x"].numel(), self.nlp["g"].numel())
            try:
                self._solver = ipopt_solver("ocp", self.nlp,
                                            {**opts, **self.block.derivative_options, "iteration_callback": self._monitor})
            except RuntimeError as exc:
                refused = _refused_options(str(exc), ipopt_options)
                if refused is None:
                    raise
                raise refused from None
            self._solver_options = opts
        setup = time.perf_counter() - started
        lbx, ubx = self._bounds(x0)
        lbg, ubg = self._boundary_values()
        if self.arcs:
            pin_arcs(self, self.arcs, lbx, ubx, lbg, ubg)
        self._monitor.reset(progress, lbg, ubg)
        started = time.perf_counter()
        with stop_on_signals(self._monitor), without_pin_warning(bool(self.arcs)):
            res = self._solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        solve_time = time.perf_counter() - started
        stats = dict(self._solver.stats())
        if stats.get("return_status") == "Invalid_Option":     # its iteration count is then not set (-1064956304)
            raise _refused_options("Invalid options were detected by Ipopt", ipopt_options)
        if self._monitor.stop_reason:
            stats.update(success=False, return_status=f"interrupted by {self._monitor.stop_reason}")
        solution = self.completed(OCPSolution.from_vector(
            self, np.asarray(res["x"]).ravel(), stats, float(res["f"]),
            {"transcription": self.build_time, "solver_setup": setup, "solve": solve_time}))
        solution.objective_scale = opts.get(OBJECTIVE_SCALING, 1.0)
        # .junction_times checks imposed arcs by them
        solution.bound_multipliers = np.asarray(res["lam_x"], float).ravel()
        solution.row_multipliers = np.asarray(res["lam_g"], float).ravel()
        if not stats.get("success", False):
            raise OCPSolveError(
                f"IPOPT did not solve '{self.problem.model.name}' with {self.scheme.label} "
                f"(N = {self.scheme.intervals}): status '{stats.get('return_status')}' after "
                f"{stats.get('iter_count')} iterations{_limit_advice(stats.get('return_status'), opts)}; "
                f"the last iterate is kept in .solution",
                solution,
            )
        solution.small_objective = small_units
        # From the problem's own guess only: a warm start's objective says nothing of whether the solve drove it to
        # zero (a target reached exactly, whose warm solves start at 1e-21 and would be scaled by 1e21).
        small = None if OBJECTIVE_SCALING in ipopt_options or warm_start is not None else small_objective_scale(
            solution.objective, opts.get(OBJECTIVE_SCALING, 1.0), lambda: self.block.grad_f(x0, [])[0])
        if small is not None:
            return self._solve_rescaled(solution, small, ipopt_options, warm_start, progress)
        return solution

    def _solve_rescaled(self, first: OCPSolution, scale: float, ipopt_options: dict, warm_start, progress) -> OCPSolution:
        """The solve again from its own start (``warm_start`` or the guess) with the objective scaled by ``scale``
        (:func:`.objective_scaling.small_objective_scale`), ``first`` being an "optimum" whose objective was too small
        for IPOPT's absolute tolerances. From its own start, not from ``first``: an unscaled solve can wander into
        another basin on its way, and a warm start stays there (Hermite-Simpson on a 1 cm, 1 g rod's swing-up: 13.67
        in the metre rod's units from ``first`` where the metre rod gives 8.913). The first solve's iterations and
        time are counted in the solution's (``stats["rescaled"]`` says so)."""
        again = self.solve({**ipopt_options, OBJECTIVE_SCALING: scale}, warm_start, progress=progress)
        again.small_objective = True        # solves warm-started from it are scaled before they start
        again.stats["rescaled"] = {"objective_before": first.objective, "iterations_before": first.iterations,
                                   "objective_scale": scale}
        again.stats["iter_count"] = again.iterations + first.iterations
        again.wall_time = {k: v + first.wall_time.get(k, 0.0) for k, v in again.wall_time.items()}
        return again


# IPOPT's statuses that mean a limit was reached, not a failure of the problem: the option that set the limit.
LIMITS = {"Maximum_Iterations_Exceeded": "ipopt.max_iter", "Maximum_CpuTime_Exceeded": "ipopt.max_cpu_time",
          "Maximum_WallTime_Exceeded": "ipopt.max_wall_time"}


def _limit_advice(status, opts: dict) -> str:
    """For a status that says a limit was reached: the option that set it, and its value in this solve."""
    name = LIMITS.get(status)
    if name is None:
        return ""
    value = opts.get(name, "IPOPT's default")
    return f" (the limit '{name}' = {value}: raise it, or start closer to the optimum)"


def _refused_options(said: str, ipopt_options: dict) -> ModelError | None:
    """The :class:`ModelError` for options that CasADi or IPOPT refused (``said``: their message), naming them;
    None if ``said`` is about something else. IPOPT prints which value it refused, and its valid range, itself."""
    given = {k: v for k, v in ipopt_options.items() if DEFAULT_IPOPT.get(k) != v}
    where = "IPOPT's options: https://coin-or.github.io/Ipopt/OPTIONS.html, passed as 'ipopt.<name>'"
    if "No such IPOPT option:" in said:
        name = said.split("No such IPOPT option:", 1)[1].strip().splitlines()[0]
        return ModelError(f"'ipopt.{name}' is not an IPOPT option ({where})")
    if "Unknown option:" in said:
        name = said.split("Unknown option:", 1)[1].strip().splitlines()[0]
        return ModelError(f"'{name}' is not an option of CasADi's nlpsol; an IPOPT option is passed as 'ipopt.{name}' ({where})")
    if "Invalid options were detected by Ipopt" in said or "type mismatch" in said:
        return ModelError(f"IPOPT refused a value among the options given, {given}: of the wrong type, out of its "
                          f"range, or not in this build (the linear solvers ma27/ma57/pardiso need their own libraries; "
                          f"MUMPS is built in). IPOPT prints a value it refuses, with its range; {where}")
    return None


def transcribe(problem, scheme: Scheme) -> Transcription:
    return Transcription(problem, scheme)
