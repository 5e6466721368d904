"""Direct collocation of an :class:`OptimalControlProblem` into an IPOPT NLP.

Variables at every collocation point ``i`` (unique times over the mesh): states
``x_i = (q_i, u_i)``, accelerations ``a_i = u'_i``, multipliers ``lambda_i``, inputs
``w_i``, and (except at ``t_0``) the kinematic slack ``gamma_i`` of Posa et al. (2016).
The state derivative at a point is ``D = (N(q) u + phi_q^T gamma, a)`` (the coordinate
rates are expressions, not variables); constraints at every point: the implicit dynamics

    M(q) a = f(q, u, t, w) + G^T lambda,

the velocity-level constraints ``G u + e = 0`` and the position-level forms
``phi(q, t) = 0``. Why this choice: imposing both ``phi = 0`` and ``G u + e = 0`` makes
the solution drift-free at every point (the contract of DESIGN.md); the slack
``gamma`` absorbs the discretization's mismatch between the two (it vanishes as the
mesh is refined), so the NLP stays consistent, as in Moco. At ``t_0`` the
acceleration-level constraint ``G a + gamma_acc = 0`` determines ``lambda_0``. The
scheme's defects tie ``x`` and ``D`` (see :mod:`ocp_constraints.transcription`).
IPOPT is called through ``casadi.nlpsol`` with exact Hessians of an SX graph.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .errors import ModelError
from .ocp import OptimalControlProblem
from .ocp_solution import OCPSolution, OCPSolveError
from .rotations import EulerSequence
from .state import project_positions
from .transcription import Scheme

DEFAULT_IPOPT = {"ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 3000,
                 "ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}


@dataclass
class Layout:
    """Where each block of the decision vector lives (all column-major blocks)."""

    n_points: int
    nx: int
    nu: int
    nc: int
    nh: int
    n_in: int
    free_time: bool

    def sizes(self) -> list[int]:
        P = self.n_points
        return [self.nx * P, self.nu * P, self.nc * P, self.n_in * P, self.nh * (P - 1), int(self.free_time)]

    def split(self, w):
        out, start = [], 0
        for n in self.sizes():
            out.append(w[start : start + n])
            start += n
        P = self.n_points
        X = ca.reshape(out[0], self.nx, P)
        A = ca.reshape(out[1], self.nu, P)
        L = ca.reshape(out[2], self.nc, P)
        W = ca.reshape(out[3], self.n_in, P)
        Gm = ca.reshape(out[4], self.nh, P - 1)
        return X, A, L, W, Gm, out[5]


class Transcription:
    """The NLP of one problem and one scheme, built once, solvable many times."""

    def __init__(self, problem: OptimalControlProblem, scheme: Scheme):
        started = time.perf_counter()
        self.problem, self.scheme = problem, scheme
        e = problem.eqs
        self.eqs = e
        nx = e.nq + e.nu
        n_in = e.inputs.numel()
        p = len(scheme.tau)
        N = scheme.intervals
        P = N * (p - 1) + 1
        self.layout = Layout(P, nx, e.nu, e.nc, e.phi.numel(), n_in, problem.t_final_bounds is not None)
        mesh = scheme.mesh_fractions
        # Normalized time of every point, and its quadrature weight (times the horizon).
        frac = np.zeros(P)
        quad = np.zeros(P)
        for k in range(N):
            hk = mesh[k + 1] - mesh[k]
            for j in range(p):
                frac[k * (p - 1) + j] = mesh[k] + scheme.tau[j] * hk
                quad[k * (p - 1) + j] += scheme.weights[j] * hk
        self.fractions, self.quadrature = frac, quad

        w = ca.SX.sym("w", sum(self.layout.sizes()))
        X, A, L, W, Gm, Tvar = self.layout.split(w)
        T = Tvar[0] if self.layout.free_time else problem.t_final
        point = self._point_functions()
        g, lbg, ubg = [], [], []

        def add(expr, lo=0.0, hi=0.0) -> int:
            """Append constraint rows; return the index of the first."""
            first, n = len(lbg), expr.numel()
            g.append(expr)
            lbg.extend([lo] * n if np.ndim(lo) == 0 else list(lo))
            ubg.extend([hi] * n if np.ndim(hi) == 0 else list(hi))
            return first

        cost = 0
        D = []  # state derivatives at the points
        for i in range(P):
            t_i = frac[i] * T
            gam = Gm[:, i - 1] if i > 0 else ca.SX.zeros(self.layout.nh)
            D.append(ca.vertcat(point["kinematics"](X[:, i], gam, t_i), A[:, i]))
            dyn, vel, pos = point["residuals"](X[:, i], A[:, i], L[:, i], W[:, i], t_i)
            add(dyn)
            add(vel)
            add(pos)
            if problem.integral_terms and quad[i] > 0:
                cost += quad[i] * T * point["integrand"](X[:, i], L[:, i], W[:, i], t_i)
            if problem.path_constraints:
                lo = [pc.lower for pc in problem.path_constraints]
                hi = [pc.upper for pc in problem.path_constraints]
                add(point["path"](X[:, i], L[:, i], W[:, i], t_i), lo, hi)
        add(point["acceleration"](X[:, 0], D[0], W[:, 0], 0 * T))
        if not scheme.first_point_has_controls and n_in and not ca.depends_on(ca.vertcat(ca.vec(e.G), e.e), e.inputs):
            # Radau never uses inputs at t0 in its defects: take the first interval's input
            # polynomial there, so that lambda_0 (from the acceleration constraint) is consistent.
            ell = scheme.start_extrapolation
            add(W[:, 0] - sum(ell[j] * W[:, j + 1] for j in range(len(ell))))
        for k in range(N):
            idx = [k * (p - 1) + j for j in range(p)]
            h = (mesh[k + 1] - mesh[k]) * T
            for defect in scheme.defects([X[:, i] for i in idx], [D[i] for i in idx], h):
                add(defect)
        self._boundary_rows = []
        for which, values in (("initial", problem.initial_values), ("final", problem.final_values)):
            i = 0 if which == "initial" else P - 1
            for name in values:
                self._boundary_rows.append((which, name, add(point["named"][name](X[:, i], W[:, i]))))
        cost += problem.time_weight * (Tvar[0] if self.layout.free_time else 0)
        self.nlp = {"x": w, "f": cost if not isinstance(cost, int) else ca.SX(0), "g": ca.vertcat(*g)}
        self._lbg, self._ubg = np.array(lbg, float), np.array(ubg, float)
        self._solver = None
        self._solver_options: dict | None = None
        self.build_time = time.perf_counter() - started

    # -- per-point pieces, as SX functions inlined into the NLP --------------------------------
    def _point_functions(self) -> dict:
        pr, e = self.problem, self.eqs
        x = ca.vertcat(e.q, e.u)
        d = ca.SX.sym("d", x.numel())
        a = ca.SX.sym("a", e.nu)
        gam = ca.SX.sym("gamma", e.phi.numel())
        lam = pr.lam
        phi_q = ca.jacobian(e.phi, e.q)
        kin = e.qdot + (phi_q.T @ gam if e.phi.numel() else 0)
        dyn = e.mass_matrix @ a - e.forces - e.G.T @ lam
        vel = e.G @ e.u + e.e
        out = {"kinematics": ca.Function("kinematics", [x, gam, e.t], [kin]),
               "residuals": ca.Function("residuals", [x, a, lam, e.inputs, e.t], [dyn, vel, e.phi])}
        pi = e.G @ e.u + e.e
        # d(pi)/dt at t0 with q' = D_q, u' = D_u; rows where an input enters are left out
        # (the input's rate there is the optimizer's free choice).
        acc = e.G @ d[e.nq :] + ca.jtimes(pi, e.q, d[: e.nq]) + ca.jacobian(pi, e.t)
        keep = [k for k in range(e.nc) if not ca.depends_on(pi[k], e.inputs)]
        out["acceleration"] = ca.Function("acceleration", [x, d, e.inputs, e.t], [acc[keep] if keep else ca.SX(0, 1)])
        if pr.integral_terms:
            integrand = sum(term.weight * term.expression for term in pr.integral_terms)
            out["integrand"] = ca.Function("integrand", [x, lam, e.inputs, e.t], [integrand])
        if pr.path_constraints:
            out["path"] = ca.Function("path", [x, lam, e.inputs, e.t], [ca.vertcat(*[c.expression for c in pr.path_constraints])])
        for term in pr.integral_terms + pr.path_constraints:
            extra = [s.name() for s in ca.symvar(term.expression) if not ca.depends_on(ca.vertcat(x, lam, e.inputs, e.t), s)]
            if extra:
                raise ModelError(f"'{term.label}' uses {extra}, which are not quantities of model '{pr.model.name}'")
        out["named"] = {n: ca.Function("boundary", [x, e.inputs], [pr.quantity(n)]) for n in {**pr.initial_values, **pr.final_values}}
        return out

    # -- bounds and guess ---------------------------------------------------------------------
    def _bounds(self, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lay, pr = self.layout, self.problem
        lo = [np.full(n, -np.inf) for n in lay.sizes()]
        hi = [np.full(n, np.inf) for n in lay.sizes()]
        names_x = pr.model.coordinate_names + pr.model.speed_names
        names_w = list(pr.model.inputs)
        for name, (a, b) in pr.bounds.items():
            if name in names_x:
                r = names_x.index(name)
                lo[0][r :: lay.nx], hi[0][r :: lay.nx] = a, b
            elif name in names_w:
                r = names_w.index(name)
                lo[3][r :: lay.n_in], hi[3][r :: lay.n_in] = a, b
            else:
                raise ModelError(f"bound on '{name}': only coordinates, speeds and inputs take bounds; use subject_to for rates")
        if lay.free_time:
            lo[5][:], hi[5][:] = pr.t_final_bounds
        self._keep_away_from_euler_singularities(lo[0], hi[0], names_x, x0[: lay.nx])
        return np.concatenate(lo), np.concatenate(hi)

    def _keep_away_from_euler_singularities(self, lo, hi, names_x, x_start) -> None:
        """Bound each Euler body's second angle inside the regular band of its start value.

        Where the user set no bound: the dual Euler basis (and so the dynamics) is
        singular at theta = k pi (proper sequences) or pi/2 + k pi (Tait-Bryan), and an
        iterate that crosses there makes IPOPT wander.
        """
        lay = self.layout
        for b in self.eqs.bodies:
            rot = b.rotation
            name = f"{b.name}.theta"
            if not isinstance(rot, EulerSequence) or name in self.problem.bounds:
                continue
            r = names_x.index(name)
            offset = 0.0 if rot.is_proper else np.pi / 2
            k = np.floor((x_start[r] + offset) / np.pi)
            margin = max(rot.singularity_tolerance, 1e-3)
            lo[r :: lay.nx] = k * np.pi - offset + margin
            hi[r :: lay.nx] = (k + 1) * np.pi - offset - margin

    def _boundary_values(self) -> tuple[np.ndarray, np.ndarray]:
        lbg, ubg = self._lbg.copy(), self._ubg.copy()
        for which, name, row in self._boundary_rows:
            v = (self.problem.initial_values if which == "initial" else self.problem.final_values)[name]
            lbg[row] = ubg[row] = v
        return lbg, ubg

    def initial_guess(self) -> np.ndarray:
        """Named guesses, else linear between boundary values; positions projected onto ``phi = 0``."""
        pr, e, lay = self.problem, self.eqs, self.layout
        T = pr.t_final
        t = self.fractions * T
        names = pr.model.coordinate_names + pr.model.speed_names
        X = np.zeros((lay.nx, lay.n_points))
        for r, n in enumerate(names):
            if n in pr.guess:
                X[r] = np.broadcast_to(pr.guess[n](t), t.shape)
            else:
                a = pr.initial_values.get(n, pr.final_values.get(n, 0.0))
                b = pr.final_values.get(n, a)
                X[r] = a + (b - a) * self.fractions
        W = np.zeros((lay.n_in, lay.n_points))
        for r, n in enumerate(pr.model.inputs):
            if n in pr.guess:
                W[r] = np.broadcast_to(pr.guess[n](t), t.shape)
            else:
                a = pr.initial_values.get(n, 0.0)
                W[r] = a + (pr.final_values.get(n, a) - a) * self.fractions
        for i in range(lay.n_points):
            X[: e.nq, i] = project_positions(e, X[: e.nq, i], t[i], inputs=W[:, i])
        A = np.gradient(X[e.nq :], t, axis=1) if lay.n_points > 1 else np.zeros((e.nu, 1))
        parts = [X.ravel(order="F"), A.ravel(order="F"), np.zeros(lay.nc * lay.n_points), W.ravel(order="F"),
                 np.zeros(lay.nh * (lay.n_points - 1)), np.array([T] if lay.free_time else [])]
        return np.concatenate(parts)

    # -- solve ----------------------------------------------------------------------------------
    def solve(self, ipopt_options: dict, warm_start=None) -> OCPSolution:
        opts = {**DEFAULT_IPOPT, **ipopt_options}
        started = time.perf_counter()
        if self._solver is None or opts != self._solver_options:
            self._solver = ca.nlpsol("ocp", "ipopt", self.nlp, opts)
            self._solver_options = opts
        setup = time.perf_counter() - started
        x0 = self.initial_guess() if warm_start is None else np.asarray(warm_start.decision_vector, float)
        lbx, ubx = self._bounds(x0)
        lbg, ubg = self._boundary_values()
        started = time.perf_counter()
        res = self._solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        solve_time = time.perf_counter() - started
        stats = self._solver.stats()
        solution = OCPSolution.from_vector(self, np.asarray(res["x"]).ravel(), stats, float(res["f"]),
                                           {"transcription": self.build_time, "solver_setup": setup, "solve": solve_time})
        if not stats.get("success", False):
            raise OCPSolveError(
                f"IPOPT did not solve '{self.problem.model.name}' with {self.scheme.label} "
                f"(N = {self.scheme.intervals}): status '{stats.get('return_status')}' after "
                f"{stats.get('iter_count')} iterations; the last iterate is kept in .solution",
                solution,
            )
        return solution


def transcribe(problem: OptimalControlProblem, scheme: Scheme) -> Transcription:
    return Transcription(problem, scheme)
