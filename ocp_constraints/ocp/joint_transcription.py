"""Direct collocation in joint coordinates: ``OptimalControlProblem(..., coordinates="joint")``.

The same transcription as :mod:`.transcription` (same schemes, elements, Posa slacks, IPOPT),
of the equations in joint coordinates (:class:`~ocp_constraints.mechanics.generalized.JointCoordinates`,
paper sec. 5, eqs. 34-44): per point the joint coordinates and speeds instead of every body's
six and six, and multipliers and slacks only for the constraints the joints' parameterizations
do not satisfy identically (loop closures, contacts, constraints written by hand).

The problem is stated as always, in the bodies' names: objectives, path constraints, bounds,
boundary values and guesses on ``rod.psi``, ``rod.omega_z``, ``problem.multiplier("hinge.v2")``,
``problem.joint_force("hinge")``. Here they become expressions of the joint coordinates: a body
coordinate or speed through the joint maps, a joint's multiplier through its body's balance
(:attr:`JointCoordinates.multiplier_expression`, with the accelerations of the reduced dynamics),
built only where a term asks for one. A bound on a body coordinate or speed becomes a path
constraint. The solution is handed back in the bodies' coordinates with every multiplier, so
``sol.sample``, ``sol.loads()``, warm starts and results files are those of the maximal form.
"""
from __future__ import annotations

from dataclasses import replace
from functools import cached_property
from types import SimpleNamespace

import casadi as ca
import numpy as np

from ..errors import ModelError
from ..mechanics.generalized import JointCoordinates
from .bounds import _keep_away_from_euler_singularities
from .free_mesh_points import scale_bounds
from .guess import consistent_guess
from .joint_guess import JointGuess
from .solution import OCPSolution
from .transcription import Transcription
from .transcription_elements import free_rate_row, of_coordinates, path_rate, state_row
from ..dynamics.trajectory import Trajectory


class ReducedProblem:
    """A view of an :class:`OptimalControlProblem` in joint coordinates (what the transcription reads)."""

    def __init__(self, problem, reduced: JointCoordinates):
        self.original, self.eqs = problem, reduced
        self.lam = reduced.multiplier_symbols[1]
        self.integral_terms = [replace(t, expression=self.translate(t.expression)) for t in problem.integral_terms]
        self.terminal_terms = [replace(t, expression=self.translate(t.expression)) for t in problem.terminal_terms]
        self.path_constraints = [replace(c, expression=self.translate(c.expression)) for c in problem.path_constraints]
        names = set(problem.model.coordinate_names + problem.model.speed_names)
        # Body coordinates and speeds are expressions here, not variables: their bounds are path rows.
        self.state_bounds = {n: b for n, b in problem.bounds.items() if n in names}
        for n, (lo, hi) in self.state_bounds.items():
            self.path_constraints.append(SimpleNamespace(label=state_row(n), expression=self.translate(problem.quantity(n)),
                                                         lower=lo, upper=hi, scale=1.0))
        # A bounded coordinate's rate, and a path constraint's of the coordinates alone: free rows (free_rate_row).
        for n in self.state_bounds:
            if n in problem.model.coordinate_names:
                self.path_constraints.append(free_rate_row(n, self.translate(problem.quantity(f"{n}_dot"))))
        for c in problem.path_constraints:
            if of_coordinates(problem, c):
                self.path_constraints.append(free_rate_row(c.label, self.translate(path_rate(problem, c))))

    def __getattr__(self, name):
        return getattr(self.original, name)

    def translate(self, expression) -> ca.SX:
        """A maximal expression (bodies' ``q, u``, multipliers, inputs, t) in joint coordinates."""
        r, pr = self.eqs, self.original
        out = r.substitute(ca.SX(expression))
        if ca.depends_on(out, pr.lam):
            a, lam_r = r.multiplier_symbols
            lam = ca.substitute(r.multiplier_expression, a, r.forward_accelerations)
            out = ca.substitute(out, pr.lam, lam)
        return out

    def quantity(self, name: str) -> ca.SX:
        return self.translate(self.original.quantity(name))


def transcribe_joint(problem, scheme) -> Transcription:
    """The joint-coordinate NLP of ``problem``; where no body hangs on a joint with a known
    parameterization, nothing changes and this is the maximal form's (the same NLP, the same start)."""
    reduced = JointCoordinates(problem.eqs)
    if not reduced.maps:
        return Transcription(problem, scheme)
    return JointTranscription(problem, scheme, reduced)


class JointTranscription(Transcription):
    """The NLP of a problem in joint coordinates; solutions come back in the bodies' coordinates."""

    rate_rows = False       # the view's own path rows hold the state bounds and their rates (ReducedProblem)

    def __init__(self, problem, scheme, reduced: JointCoordinates | None = None, like: JointTranscription | None = None):
        """``like``: a joint transcription of the same problem, unchanged since (a refinement's earlier mesh):
        its joint coordinates, problem view and point functions are taken, not built again."""
        self.user_problem = problem
        if like is not None:
            self.reduced, view = like.reduced, like.problem
        else:
            self.reduced = JointCoordinates(problem.eqs) if reduced is None else reduced
            view = ReducedProblem(problem, self.reduced)
        super().__init__(view, scheme, like)

    # -- bounds ----------------------------------------------------------------------------------
    def _bounds(self, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inputs' bounds on the input variables, the free final time's; state bounds are path rows."""
        lay, pr = self.layout, self.user_problem
        lo = [np.full(n, -np.inf) for n in lay.sizes()]
        hi = [np.full(n, np.inf) for n in lay.sizes()]
        names_w = list(pr.model.inputs)
        for name, (a, b) in pr.bounds.items():
            if name in names_w:
                r = names_w.index(name)
                lo[3][r :: lay.n_in], hi[3][r :: lay.n_in] = a, b
            elif name not in self.problem.state_bounds:
                raise ModelError(f"bound on '{name}': only coordinates, speeds and inputs take bounds; use subject_to "
                                 f"for rates")
        if lay.free_time:
            lo[5][:], hi[5][:] = pr.t_final_bounds
        if lay.n_phases:
            lo[6][:], hi[6][:] = scale_bounds(self)
        # A body on no mapped joint keeps its Euler angles: the same bands off their singularities.
        free = [b for b in self.reduced.bodies if b.name not in self.reduced.maps]
        names = self.reduced.coordinate_names + self.reduced.speed_names
        view = SimpleNamespace(layout=lay, eqs=SimpleNamespace(bodies=free), problem=pr)
        _keep_away_from_euler_singularities(view, lo[0], hi[0], names, x0[: lay.nx])
        return np.concatenate(lo), np.concatenate(hi)

    # -- guesses ---------------------------------------------------------------------------------
    def initial_guess(self) -> np.ndarray:
        """A consistent start from the user's guesses on the bodies' names (:mod:`.joint_guess`)."""
        pr, e = self.user_problem, self.user_problem.eqs
        t = self.fractions * pr.t_final
        P = len(t)
        X = np.full((e.nq + e.nu, P), np.nan)
        for r, n in enumerate(pr.model.coordinate_names + pr.model.speed_names):
            if n in pr.guess:
                X[r] = np.broadcast_to(pr.guess[n](t), t.shape)
            elif n in pr.initial_values or n in pr.final_values or r >= e.nq:
                a = pr.initial_values.get(n, pr.final_values.get(n, 0.0))
                X[r] = a + (pr.final_values.get(n, a) - a) * self.fractions
        W = np.full((e.inputs.numel(), P), np.nan)
        for r, n in enumerate(pr.model.inputs):
            if n in pr.guess:
                W[r] = np.broadcast_to(pr.guess[n](t), t.shape)
        start, reduced = self._start, self.reduced
        if reduced.phi.numel():
            # A loop closure or contact stays: the maximal form's consistent positions (on every
            # constraint, the boundary values and guesses kept), fitted exactly by the joint coordinates.
            maximal = SimpleNamespace(eqs=e, problem=pr, fractions=self.fractions, layout=SimpleNamespace(n_acc=P),
                                      accelerations=lambda X, A, t_final: A)
            Xm = consistent_guess(maximal, np.vstack([np.nan_to_num(X[: e.nq]), X[e.nq :]]), W, pr.t_final)[0]
            p = start.coordinates(Xm[: e.nq], t)
        else:
            p = start.coordinates(X[: e.nq], t)
        if reduced.phi.numel() and not any(n in pr.guess for n in pr.model.speed_names) and P > 1:
            # A loop with no speed guessed: the joint coordinates' own rates (p' = u_r), so the start has
            # no kinematic defect. Measured on the suite's four-bar, Radau 3: N = 40 from 261 to 75 IPOPT
            # iterations (N = 20: 57 -> 65); for trees the boundary speeds (as in the maximal form) did
            # better (swing-up N = 25: 8 against 13 iterations; the projected rates: four-bar N = 40, 158).
            U = self._speeds_from_rates(p, np.gradient(p, t, axis=1))
        else:
            U = start.speeds(p, X[e.nq :], t, np.nan_to_num(W))
        A = np.gradient(U, t, axis=1) if P > 1 else np.zeros_like(U)
        A = self.accelerations(np.vstack([p, U]), A[:, : self.layout.n_acc], pr.t_final)
        L, W = start.loads(p, U, A, t, W)
        for r, name in enumerate(pr.model.inputs):
            lo, hi = pr.bounds.get(name, (-np.inf, np.inf))
            W[r] = np.clip(W[r], lo, hi)
        return self._pack(np.vstack([p, U]), L, W, pr.t_final, A=A)

    def _speeds_from_rates(self, p: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """Speeds whose coordinate rates ``p' = N(p) u_r`` are nearest to ``rates`` (least squares, point by point):
        the rates themselves where every body hangs on a mapped joint; not for a body that keeps its own
        coordinates (its angular velocity is not its Euler angles' rates, and a quaternion has 4 rates for 3
        speeds: a raw CasADi shape error before)."""
        r = self.reduced
        if all(b.name in r.maps for b in r.bodies):
            return rates
        N = ca.Function("rate_matrix", [r.q], [ca.jacobian(r.qdot, r.u)])
        return np.column_stack([np.linalg.lstsq(np.asarray(N(p[:, i])), rates[:, i], rcond=None)[0]
                                for i in range(p.shape[1])])

    @cached_property
    def _start(self) -> JointGuess:
        return JointGuess(self.reduced)

    def guess_from(self, solution: OCPSolution) -> np.ndarray:
        """A start from a solution of this problem (maximal or joint coordinates, any mesh or scheme)."""
        if getattr(solution, "transcription", None) is self:
            return np.asarray(solution.decision_vector, float)
        theirs = getattr(solution, "transcription", None)
        if isinstance(theirs, JointTranscription) and theirs.reduced is self.reduced:
            # The same joint coordinates on another mesh (mesh refinement): their own polynomials at
            # these points, no fit of the joint coordinates to the bodies' (a third of a refinement's guess time).
            X, _, L, W, _, _ = (np.asarray(a, float) for a in theirs.layout.split(np.asarray(solution.decision_vector, float)))
            E = theirs.interpolation_matrix(self.fractions)
            X, L, W = X @ E.T, L @ E.T, W @ E.T
            t = self.fractions * solution.t_final
            A = np.gradient(X[self.reduced.nq :], t, axis=1) if len(t) > 1 else np.zeros((self.reduced.nu, 1))
            return self._pack(X, L, W, solution.t_final, A=self.accelerations(X, A[:, : self.layout.n_acc], solution.t_final))
        if not isinstance(solution, OCPSolution):
            raise ModelError(f"warm_start must be a solution from problem.solve (an OCPSolution, or an "
                             f"OCPSolveError's .solution), got {type(solution).__name__}")
        pr, e = self.user_problem, self.user_problem.eqs
        theirs = solution.trajectory.eqs
        if theirs.constraint_names != e.constraint_names or list(theirs.model.inputs) != list(pr.model.inputs):
            raise ModelError(f"warm_start: the solution is of model '{theirs.model.name}' with constraints "
                             f"{theirs.constraint_names}; pass a solution of this problem's model '{pr.model.name}'")
        t = self.fractions * solution.t_final
        X = np.array([solution.polynomial(n, t) for n in pr.model.coordinate_names + pr.model.speed_names])
        L = np.array([solution.polynomial(f"{c}.lambda", t) for c in e.constraint_names]).reshape(e.nc, -1)
        W = np.array([solution.polynomial(n, t) for n in pr.model.inputs]).reshape(e.inputs.numel(), -1)
        return self._from_maximal(X, L, W, solution.t_final)

    def _from_maximal(self, X: np.ndarray, L: np.ndarray, W: np.ndarray, t_final: float) -> np.ndarray:
        """Joint coordinates fitted to the bodies' coordinates at every point (Gauss-Newton on all
        points at once, from the joint coordinates' zero: the Euler angles are unwrapped about their
        linearization there, see :mod:`~ocp_constraints.mechanics.generalized`), speeds ``u_r`` by least
        squares on ``u = J u_r``, accelerations from the speeds, the remaining constraints'
        multipliers as they were."""
        r, full = self.reduced, self.user_problem.eqs
        t = self.fractions * t_final
        p = self._start.coordinates(X[: full.nq], t)
        Jm = np.asarray(r.pose_functions.map(len(t))(p)[2]).reshape(full.nu, len(t), r.nu).transpose(1, 0, 2)
        U = (np.linalg.pinv(Jm) @ X[full.nq :].T[:, :, None])[:, :, 0].T
        A = np.gradient(U, t, axis=1) if len(t) > 1 else np.zeros_like(U)
        A = self.accelerations(np.vstack([p, U]), A[:, : self.layout.n_acc], t_final)
        return self._pack(np.vstack([p, U]), L[r.rest], W, t_final, A=A)

    # -- solving ---------------------------------------------------------------------------------
    def completed(self, sol: OCPSolution) -> OCPSolution:
        """The bodies' coordinates, speeds, accelerations and every multiplier at each point (also of a
        failed solve's last iterate)."""
        r, full = self.reduced, self.user_problem.eqs
        P = len(sol.t)
        q, u, udot, lam = (np.asarray(v).reshape(-1, P) for v in r.maximal_function.map(P)(
            sol.X[: r.nq], sol.X[r.nq :], sol.D, sol.lam, sol.inputs, sol.t[None, :]))
        traj = Trajectory(full, sol.success, sol.status)
        traj.extend(sol.t, q.T, u.T, udot.T, lam.T, sol.inputs.T, np.zeros((P, full.nc)), np.zeros(P), np.zeros(P),
                    np.zeros(P))     # all points in one block
        return OCPSolution(sol.transcription, sol.decision_vector, sol.t, np.vstack([q, u]), udot, lam, sol.inputs, sol.t_final,
                           sol.objective, sol.stats, sol.wall_time, traj)

