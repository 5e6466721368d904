"""The maximal transcription condensed: ``OptimalControlProblem(..., coordinates="condensed")``.

The same collocation as :mod:`.transcription` (schemes, elements, IPOPT, every body's coordinates and
speeds at every point), with the accelerations and multipliers no longer NLP variables: at every
point they are the solution of the point's KKT system (paper eq. 13 with the loads of eq. 26 and
the constraints' acceleration level, :mod:`.condensed_kkt`), ``u' = a(q, u, t, w)`` and
``lambda = lambda(q, u, t, w)``, inside the interval's element. Per point the NLP keeps ``q, u, w``.

Why the constraints still hold: the KKT solution keeps ``d(pi)/dt = 0`` at every collocation point,
so ``pi = G u + e`` (and ``phi``) drift only by the scheme's error over an interval. At the
``slack`` points the maximal form's rows ``phi = 0`` and ``G u + e = 0`` are imposed, each with its
slack: Posa et al.'s ``q' = N u + phi_q^T gamma`` (Posa, Cantu, Tedrake 2016) and the velocity-level
``s`` (``u' = a + da s``, ``lambda = lambda + dlam s``: any ``(u', lambda)`` that satisfies the balance
``M u' = f + G^T lambda``, see :class:`~.condensed_kkt.PointwiseKKT`).

- ``slacks="mesh"`` (the default): slacks and rows only at the mesh points (interval ends) and
  the rows at ``t_0``; interior collocation points carry neither. A different discretization of the
  same DAE than the maximal form's (which imposes the rows at every point): the two agree to the
  scheme's error and converge to the same optimum as the mesh is refined.
- ``slacks="points"``: at every point after ``t_0``, as the maximal form. Then this is the maximal
  NLP with its accelerations eliminated (``M u' = f + G^T lambda`` solved for ``u'``) and its
  multipliers written as ``lambda_KKT + dlam s``: the same optimum, to IPOPT's tolerance.

Multipliers, loads and power are expressions of the point's variables, so objectives and path
constraints on them (friction cones, load bounds) are rows of the point elements, and the solution
is handed back with every multiplier at every point, as the maximal form's.

Why ``coordinates="auto"`` does not choose this form (Radau 3, N = 20, CPU seconds maximal ->
condensed, ``python scripts/ocp_condensed_bench.py``): it wins where the maximal NLP needs many
iterations (quadrotor with load 1.92 -> 0.58, 18 -> 7 iterations; rolling disk 2.80 -> 1.30,
198 -> 44) and loses elsewhere (the issue's textbook cart-pole written by hand 0.51 -> 2.00, the
swing-up with a hand-written hinge 0.31 -> 0.65, ball_socket reach 2.34 -> 2.80, four-bar
7.2 -> 128): the exact Hessian of a symbolic KKT solution costs 10-20 times the maximal form's
nearly linear dynamics rows per iteration (textbook: 46 ms against 2.3 ms per Hessian call), and
with mesh slacks the constraints hold at the mesh points only (between them they drift by the
scheme's error, where DESIGN.md asks for solver tolerance at every collocation point).
"""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import casadi as ca
import numpy as np

from .condensed_kkt import pointwise_kkt
from .guess import consistent_guess
from .layout import Layout
from .nlp_assembly import element
from .solution import OCPSolution
from .transcription_elements import scaled_path_bounds
from .transcription import Transcription
from ..dynamics.trajectory import Trajectory
from ..errors import ModelError

SLACKS = ("mesh", "points")


@dataclass
class CondensedLayout(Layout):
    """States and inputs at every point; velocity (``s``) and Posa (``gamma``) slacks at ``slack_points`` only."""

    slack_points: tuple = ()

    def sizes(self) -> list[int]:
        P, S = self.n_points, len(self.slack_points)
        return [self.nx * P, 0, self.nc * S, self.n_in * P, self.nh * S, int(self.free_time), 0]

    def split(self, w):
        """Numeric blocks at every point: ``X, A`` (zeros: not variables), ``s`` (zero off the slack
        points), ``W``, ``gamma`` (points after ``t_0``), ``T``."""
        w = np.asarray(w, float).ravel()
        bounds = np.cumsum([0, *self.sizes()])
        X, s, W, g, T = (w[bounds[b] : bounds[b + 1]] for b in (0, 2, 3, 4, 5))
        P, sp = self.n_points, list(self.slack_points)
        S = np.zeros((self.nc, P))
        S[:, sp] = s.reshape(self.nc, -1, order="F")
        Gm = np.zeros((self.nh, P))
        Gm[:, sp] = g.reshape(self.nh, -1, order="F")
        return (X.reshape(self.nx, P, order="F"), np.zeros((self.nu, P)), S, W.reshape(self.n_in, P, order="F"),
                Gm[:, 1:], T)


class CondensedTranscription(Transcription):
    """The maximal NLP without acceleration and multiplier variables (see the module docstring)."""

    rate_rows = False       # its path rows are its own (no arc is imposed on it: .imposed_arcs.path_rows)

    def __init__(self, problem, scheme, slacks: str = "mesh"):
        if slacks not in SLACKS:
            raise ModelError(f"slacks must be one of {', '.join(SLACKS)}, got {slacks!r}")
        self.slacks = slacks
        self.kkt = pointwise_kkt(problem.eqs)
        super().__init__(problem, scheme)

    # -- layout -------------------------------------------------------------------------------------
    def _slack_points(self, P: int) -> tuple:
        if self.slacks == "points":
            return tuple(range(1, P))
        return tuple(int(self.offsets[k + 1]) for k in range(len(self.local)))

    def _indices(self) -> dict:
        """Where each point's blocks sit; the slacks of a point without them read a fixed zero."""
        lay = self.layout
        start = np.concatenate([[0], np.cumsum(lay.sizes())])
        where = {p: r for r, p in enumerate(lay.slack_points)}

        def block(b: int, size: int):
            return lambda i: start[b] + i * size + np.arange(size)

        def slack(b: int, size: int):
            return lambda i: start[b] + where[i] * size + np.arange(size) if i in where else -np.ones(size, int)

        return {"x": block(0, lay.nx), "a": lambda i: -np.ones(lay.nu, int), "lam": slack(2, lay.nc),
                "w": block(3, lay.n_in), "gamma": slack(4, lay.nh), "T": [start[5]] if lay.free_time else [],
                "phases": start[6]}

    @property
    def layout(self) -> CondensedLayout:
        return self._layout

    @layout.setter
    def layout(self, base: Layout) -> None:
        # The maximal form's layout, set by Transcription.__init__: the same points, no acceleration
        # or multiplier blocks, slacks at the slack points only; u' is the KKT's everywhere.
        self.from_speeds = False
        self._layout = base if isinstance(base, CondensedLayout) else CondensedLayout(
            base.n_points, base.nx, base.nu, base.nc, base.nh, base.n_in, base.free_time, 0,
            slack_points=self._slack_points(base.n_points))

    # -- elements ---------------------------------------------------------------------------------------
    def _point_functions(self) -> dict:
        out = super()._point_functions()
        e, k = self.eqs, self.kkt
        x = ca.vertcat(e.q, e.u)
        s, gam = ca.SX.sym("s", e.nc), ca.SX.sym("gamma", e.position_rows.numel())
        args = [x, e.inputs, s, gam, e.t]
        out["rates"] = ca.Function("rates", args, [out["kinematics"](x, gam, e.t), k.a + k.da @ s])
        out["multipliers"] = ca.Function("multipliers", [x, e.inputs, s, e.t], [k.lam + k.dlam @ s])
        out["constraints"] = ca.Function("constraints", [x, e.t], [ca.vertcat(e.G @ e.u + e.e, e.position_rows)])
        return out

    def _point_elements(self, s) -> list:
        """Path rows and the integrand at every point (multipliers from the KKT); ``G u + e = 0`` and
        ``phi = 0`` at ``t_0`` and at the slack points."""
        pr, lay, index = self.problem, self.layout, s.index
        x, w, T = s.x, s.w, s.T
        sv = ca.SX.sym("s", lay.nc)
        frac, quad = ca.SX.sym("frac"), ca.SX.sym("quad")
        t = frac * T
        out = []
        if pr.path_constraints or pr.integral_terms:
            lam = s.point["multipliers"](x, w, sv, t)
            rows = s.point["path"](x, lam, w, t) if pr.path_constraints else ca.SX(0, 1)
            cost = quad * T * s.point["integrand"](x, lam, w, t) if pr.integral_terms else ca.SX(0)
            out.append(element("point", ca.vertcat(x, w, sv, *s.T_z), ca.vertcat(frac, quad, *s.T_c), rows, cost,
                               [np.concatenate([index["x"](i), index["w"](i), index["lam"](i), index["T"]])
                                for i in range(lay.n_points)],
                               [[self.fractions[i], self.quadrature[i], *s.T_value] for i in range(lay.n_points)],
                               *scaled_path_bounds(pr.path_constraints)))
        held = [0, *lay.slack_points]
        # Where each held point's position rows are (after G u + e = 0): Transcription._fixed_length_rows.
        self.position_rows_at = {int(i): ("constraints", r, lay.nc) for r, i in enumerate(held)}
        if lay.nc or lay.nh:
            out.append(element("constraints", ca.vertcat(x, *s.T_z), ca.vertcat(frac, *s.T_c),
                               s.point["constraints"](x, t), 0,
                               [np.concatenate([index["x"](i), index["T"]]) for i in held],
                               [[self.fractions[i], *s.T_value] for i in held]))
        return out

    def _interval_elements(self, s) -> list:
        """The scheme's defects on every interval, ``D = (N u + phi_q^T gamma, a + da s)`` at each point."""
        lay, index = self.layout, s.index
        mesh, groups = self.scheme.mesh_fractions, self._groups()
        out = []
        for label, (local, intervals) in groups.items():
            p = len(local.tau)
            xs = [ca.SX.sym(f"x{j}", lay.nx) for j in range(p)]
            ws = [ca.SX.sym(f"w{j}", lay.n_in) for j in range(p)]
            ss = [ca.SX.sym(f"s{j}", lay.nc) for j in range(p)]
            gs = [ca.SX.sym(f"gamma{j}", lay.nh) for j in range(p)]
            fractions, h = ca.SX.sym("frac", p), ca.SX.sym("h")
            D = [ca.vertcat(*s.point["rates"](xs[j], ws[j], ss[j], gs[j], fractions[j] * s.T)) for j in range(p)]
            defects = local.defects(xs, D, h * s.T)

            def variables(k: int) -> np.ndarray:
                points = self.interval_points(k)
                return np.concatenate([*(index[b](i) for b in ("x", "w", "lam", "gamma") for i in points), index["T"]])

            out.append(element("interval" if len(groups) == 1 else f"interval_{label}",
                               ca.vertcat(*xs, *ws, *ss, *gs, *s.T_z), ca.vertcat(fractions, h, *s.T_c),
                               ca.vertcat(*defects), 0, [variables(k) for k in intervals],
                               [[*self.fractions[list(self.interval_points(k))], mesh[k + 1] - mesh[k], *s.T_value]
                                for k in intervals]))
        return out

    def _end_elements(self, s) -> list:
        """Boundary values, Radau's input extrapolation and the final time, as the maximal form's; no
        acceleration rows at ``t_0`` (the KKT solution satisfies them)."""
        return [el for el in super()._end_elements(s) if el.name != "acceleration"]

    # -- guesses ------------------------------------------------------------------------------------------
    def initial_guess(self) -> np.ndarray:
        """The maximal form's consistent start (:mod:`.guess`): states and inputs; slacks zero."""
        X, W = self._user_guess()
        P = self.layout.n_points
        view = SimpleNamespace(eqs=self.eqs, problem=self.problem, fractions=self.fractions,
                               layout=SimpleNamespace(n_acc=P), accelerations=lambda X, A, t_final: A)
        X, _, L, W = consistent_guess(view, X, W, self.problem.t_final)
        return self._pack(X, L, W, self.problem.t_final, A=np.zeros((self.eqs.nu, P)))

    def _pack(self, X, L, W, t_final: float, A: np.ndarray | None = None) -> np.ndarray:
        """States and inputs (positions projected onto ``phi = 0`` for a warm start), slacks zero."""
        lay = self.layout
        if A is None:
            self._project_positions(X, W, self.fractions * t_final)
        S = len(lay.slack_points)
        return np.concatenate([X.ravel(order="F"), np.zeros(lay.nc * S), W.ravel(order="F"), np.zeros(lay.nh * S),
                               np.array([t_final] if lay.free_time else [])])

    def accelerations(self, X: np.ndarray, A: np.ndarray, t_final: float) -> np.ndarray:
        return A      # placeholders; :meth:`completed` puts the KKT's in

    # -- solving -----------------------------------------------------------------------------------------
    def completed(self, sol: OCPSolution) -> OCPSolution:
        """``u'`` and ``lambda`` at every point from the states, inputs and slacks of ``sol`` (also of a
        failed solve's last iterate)."""
        e, P = self.eqs, len(sol.t)
        point = self.__dict__.setdefault("_numeric", self._point_functions())
        zero = np.zeros((e.position_rows.numel(), P))
        udot = np.asarray(point["rates"].map(P)(sol.X, sol.inputs, sol.lam, zero, sol.t[None, :])[1]).reshape(e.nu, P)
        lam = np.asarray(point["multipliers"].map(P)(sol.X, sol.inputs, sol.lam, sol.t[None, :])).reshape(e.nc, P)
        traj = Trajectory(e, sol.success, sol.status)
        traj.extend(sol.t, sol.X[: e.nq].T, sol.X[e.nq :].T, udot.T, lam.T, sol.inputs.T, np.zeros((P, e.nc)),
                    np.zeros(P), np.zeros(P), np.zeros(P))     # all points in one block
        return OCPSolution(self, sol.decision_vector, sol.t, sol.X, udot, lam, sol.inputs, sol.t_final,
                           sol.objective, sol.stats, sol.wall_time, traj)


def transcribe_condensed(problem, scheme, slacks: str = "mesh") -> CondensedTranscription:
    """The condensed maximal NLP of ``problem`` with ``scheme`` (see the module docstring)."""
    if scheme.free_points:
        raise ModelError("free_points: the condensed NLP has no phases of unknown length; use coordinates='maximal' or "
                         "'joint' (or 'auto')")
    return CondensedTranscription(problem, scheme, slacks)
