"""The result of an optimal-control solve, queried by name.

``sol.sample("rod.psi")``, ``sol.loads()["hinge.M_z"]``, ``sol.interpolate("motor", t)``;
``sol.success``, ``sol.status``, ``sol.iterations``, ``sol.objective``, wall times, and
the constraint residuals at every collocation point. The samples are the collocation
points (mesh points and interior points, in time order).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..dynamics.result import Result
from ..dynamics.trajectory import Trajectory
from ..errors import JumpWindowWarning, ModelError
from .free_mesh_points import solved_view
from .interpolation import interval_of, jumps_at_starts, starts_shared


@dataclass
class OCPSolution(Result):
    """States, accelerations ``D = u'``, multipliers and inputs at the collocation points, and solver stats.

    Answers the common vocabulary (:mod:`ocp_constraints.dynamics.result`) through
    :attr:`trajectory`, the collocation points as a :class:`Trajectory` (its ``success``
    and ``status`` are IPOPT's, as here).
    """

    transcription: object
    decision_vector: np.ndarray
    t: np.ndarray
    X: np.ndarray
    D: np.ndarray
    lam: np.ndarray
    inputs: np.ndarray
    t_final: float
    objective: float
    stats: dict
    wall_time: dict
    trajectory: Trajectory = field(repr=False, default=None)
    # Filled by problem.solve(tolerance=...): final mesh, estimate per quantity, history (mesh_refinement.py).
    mesh_refinement: dict | None = field(repr=False, default=None)

    @classmethod
    def from_vector(cls, tr, w: np.ndarray, stats: dict, objective: float, wall_time: dict) -> "OCPSolution":
        tr = solved_view(tr, w)       # free mesh points: the mesh at their solved times
        lay = tr.layout
        X, A, L, W, _, T = (np.asarray(a, float) for a in lay.split(w))
        t_final = float(T[0]) if lay.free_time else float(tr.problem.t_final)
        D = tr.accelerations(X, A, t_final)
        t = tr.fractions * t_final
        eqs = tr.eqs
        traj = Trajectory(eqs, bool(stats.get("success", False)), str(stats.get("return_status", "unknown")))
        P = lay.n_points      # all points in one block (one append per point cost ~0.1 ms each)
        traj.extend(t, X[: eqs.nq].T, X[eqs.nq :].T, D.T, L.T, W.T, np.zeros((P, eqs.nc)), np.zeros(P), np.zeros(P),
                    np.zeros(P))
        return cls(tr, w, t, X, D, L, W, t_final, objective, dict(stats), wall_time, traj)

    # -- status -------------------------------------------------------------------------------
    @property
    def success(self) -> bool:
        return bool(self.stats.get("success", False))

    @property
    def status(self) -> str:
        return str(self.stats.get("return_status", "unknown"))

    @property
    def iterations(self) -> int:
        return int(self.stats.get("iter_count", -1))

    def residuals(self) -> tuple[float, float]:
        """Largest position- and velocity-level constraint residuals over all points."""
        return self.trajectory.residuals()

    # -- named access -------------------------------------------------------------------------
    def sample_columns(self) -> dict[str, np.ndarray]:
        """Coordinates, rates, speeds, multipliers (``<constraint>.lambda``) and inputs at every point."""
        return self.trajectory.sample_columns()

    def loads(self) -> dict[str, np.ndarray]:
        """Per constraint ``lambda`` and per joint ``F``, ``M``, ``point``, ``power`` (DESIGN.md)."""
        return self.trajectory.loads()

    def load_about(self, joint: str, point) -> tuple[np.ndarray, np.ndarray]:
        """A joint load moved to the material ``point`` at every point (eq. 33), samples x 3 each."""
        return self.trajectory.load_about(joint, point)

    def polynomial(self, name: str, times) -> np.ndarray:
        """A named quantity at ``times`` (s) through each interval's collocation polynomial, as it is.

        Radau: the Lagrange polynomial through the interval's points; trapezoidal and
        Hermite-Simpson: the same construction through their points (the state
        polynomials of those schemes have the same degree). Warm starts and the error
        estimate read this; a user reads :meth:`interpolate`, which does not overshoot
        across a located jump.
        """
        times = self._within_horizon(name, times)
        # One matrix for all times (an hp mesh: each interval its own degree), in normalized time;
        # kept for the last times asked, since a warm start asks for every quantity at the same ones.
        key, cached = times.tobytes(), self.__dict__.get("_interpolation")
        if cached is None or cached[0] != key:
            cached = self.__dict__["_interpolation"] = (key, self.transcription.interpolation_matrix(times / self.t_final))
        return cached[1] @ self.sample(name)

    def interpolate(self, name: str, times) -> np.ndarray:
        """A named quantity at ``times`` (s) between the points: each interval's collocation polynomial.

        The polynomial through the interval's points, its start included (:meth:`polynomial`), except
        after a mesh point where an input jumps (:func:`.interpolation.jumps_at_starts`): there the inputs
        and multipliers come from the interval's own collocation points only. A Radau interval's start is
        the previous interval's last collocation point; through it a bang-bang motor of +-1 N m read up to
        1.88 N m off in an interval whose every point held -1.

        A refined solve (``solve(tolerance=...)``) records where a bang-bang input jumps between its
        bounds (:meth:`jump_windows`), and the estimate leaves these windows out for the inputs and
        multipliers: a time inside one gives a :class:`~ocp_constraints.errors.JumpWindowWarning` naming
        it. A jump located at a mesh point is exact as above. In an interval with a jump located inside it
        (``switches_located``, ``"inside"``), a polynomial through its points overshoots (a torque bounded
        by 0.9 read -1.47, a hinge force was off by the largest load): there the values are linear through
        the interval's own points (within their values; held at the first one back to the interval's
        start). States are continuous there and keep their polynomial.
        """
        values, inside, windows = self._interpolated(name, times)
        if inside.any():
            spots = ", ".join(f"{lo:.6g}-{hi:.6g} s" for lo, hi in windows[:3])
            warnings.warn(
                f"interpolate('{name}'): {int(inside.sum())} of the times lie in a jump window ({spots}), where "
                f"the inputs and multipliers jump (a bang-bang input's switch) and the error estimate does not "
                f"cover them; in an interval with the jump inside it the values are linear between its points. "
                f"sample('{name}') gives the points themselves", JumpWindowWarning, stacklevel=2)
        return values

    def jump_windows(self) -> list[tuple[float, float]]:
        """``(from, to)`` times (s) where a refined solve located a bang-bang input's jump, with a mesh
        point inside: the mesh intervals its bracket touches (``mesh_refinement["jump_windows"]``, as
        fractions of the horizon). Empty for a solve on a given mesh."""
        record = self.mesh_refinement or {}
        return [(lo * self.t_final, hi * self.t_final) for lo, hi in record.get("jump_windows", [])]

    def _within_horizon(self, name: str, times) -> np.ndarray:
        times = np.atleast_1d(np.asarray(times, dtype=float))
        slack = 1e-6 * self.t_final          # rounding (another solution's final time): held at the ends
        outside = times[(times < -slack) | (times > self.t_final + slack)]
        if outside.size:    # a polynomial extrapolated past the horizon is no solution value (it returned -4 for x)
            raise ModelError(f"interpolate('{name}'): time(s) {outside[:3].tolist()} s lie outside the horizon "
                             f"0 ... {self.t_final:g} s")
        return np.clip(times, 0.0, self.t_final)

    def _interpolated(self, name: str, times) -> tuple[np.ndarray, np.ndarray, list]:
        """:meth:`interpolate`'s values, which times fell inside a jump window, and the windows (s)."""
        traj, tr = self.trajectory, self.transcription
        values = self.polynomial(name, times)
        times = self._within_horizon(name, times)
        windows = self.jump_windows()
        inside = np.zeros(times.shape, bool)
        if not (name in traj.multiplier_columns() or name in traj.input_columns()):
            return values, inside, windows
        values, samples = values.copy(), self.sample(name)
        k_of = interval_of(tr, times / self.t_final, ending=True)
        jumped = (jumps_at_starts(tr, samples) | self._input_jumps())[k_of]
        if jumped.any():
            values[jumped] = tr.interpolation_matrix(times[jumped] / self.t_final, algebraic=True) @ samples
        for lo, hi in windows:
            inside |= (times > lo) & (times < hi)
        # In an interval with a jump located inside it any polynomial overshoots: linear through its own points.
        jumps = [w["fraction"] for w in (self.mesh_refinement or {}).get("switches_located", [])
                 if w["kind"] == "bang-bang" and w["inside"]]
        if inside.any() and jumps:
            rough, shared = set(interval_of(tr, np.asarray(jumps, float)).tolist()), starts_shared(tr)
            for row in np.flatnonzero(inside):
                k = int(k_of[row])
                if k in rough:
                    used = np.asarray(tr.interval_points(k))[int(shared[k]):]
                    values[row] = np.interp(times[row], self.t[used], samples[used])
        return values, inside, windows

    def _input_jumps(self) -> np.ndarray:
        """Per interval: whether an input jumps at its start (:func:`.interpolation.jumps_at_starts`). Every multiplier
        jumps with it (the accelerations do), and a multiplier's own jump can hide in its spread over the interval (a
        hinge's centripetal part). Kept on the solution: :meth:`interpolate` asks it for every quantity."""
        kept = self.__dict__.get("_input_jump_starts")
        if kept is None:
            kept = np.zeros(self.transcription.scheme.intervals, bool)
            for u in self.trajectory.input_columns():
                kept |= jumps_at_starts(self.transcription, self.sample(u))
            self.__dict__["_input_jump_starts"] = kept
        return kept

    def violations(self, tol: float = 1e-6, top: int = 5) -> list[tuple[str, float, float]]:
        """The problem's rows this solution violates most, by name, worst first: ``(what, amount, t)``.

        For a failed solve (an :class:`~ocp_constraints.errors.OCPSolveError`'s ``.solution``, e.g. IPOPT's
        'Infeasible_Problem_Detected'): path constraints by their label (friction cones, load bounds),
        bounds and boundary values by their quantity, in the problem's units, at the point where each
        is worst; only amounts above ``tol``. The dynamics defects are not included.
        """
        tr = self.transcription
        pr = getattr(tr, "user_problem", tr.problem)     # a joint-coordinate NLP: the user's problem
        e, traj, t = pr.eqs, self.trajectory, self.t
        found: list[tuple[str, float, float]] = []

        def worst(what: str, amount: np.ndarray) -> None:
            k = int(np.argmax(amount))
            if amount[k] > tol:
                found.append((what, float(amount[k]), float(t[k])))

        if pr.path_constraints:
            f = ca.Function("path", [e.q, e.u, e.inputs, pr.lam, e.t],
                            [ca.vertcat(*[c.expression for c in pr.path_constraints])]).map(len(t))
            g = np.asarray(f(np.asarray(traj.q).T, np.asarray(traj.u).T, np.asarray(traj.inputs).T,
                             np.asarray(traj.lam).T, t[None, :])).reshape(len(pr.path_constraints), len(t))
            for c, row in zip(pr.path_constraints, g):
                worst(f"path constraint '{c.label}' ({c.lower:g} <= . <= {c.upper:g})",
                      np.maximum(c.lower - row, row - c.upper))
        for name, (lo, hi) in pr.bounds.items():
            v = self.sample(name)
            worst(f"bound on '{name}' [{lo:g}, {hi:g}]", np.maximum(lo - v, v - hi))
        for which, values, k in (("initial", pr.initial_values, 0), ("final", pr.final_values, -1)):
            for name, v in values.items():
                amount = abs(float(self.sample(name)[k]) - v)
                if amount > tol:
                    found.append((f"{which} value of '{name}' = {v:g}", amount, float(t[k])))
        return sorted(found, key=lambda x: -x[1])[:top]

    def joint_work(self) -> dict[str, float]:
        """Work of each joint load over the horizon (J): the scheme's quadrature of ``power``."""
        quad = self.transcription.quadrature * self.t_final
        loads = self.loads()
        return {ch.prefix: float(quad @ loads[f"{ch.prefix}.power"]) for ch in self.trajectory.eqs.load_channels}

    def reintegrate(self, dt: float | None = None) -> dict:
        """Forward-simulate the optimal inputs from the initial state and report the deviation.

        The inputs are the collocation polynomials (linear between simulator samples);
        the simulator is the core's (CVODES, rtol 1e-12). Returns the largest deviation of
        the coordinates and speeds over the samples and at the final time, and the
        simulated :class:`Trajectory`.
        """
        from ..dynamics.simulate import SimulationOptions, simulate

        eqs = self.trajectory.eqs      # the bodies' equations (also for a joint-coordinate transcription)
        names = list(eqs.model.inputs)
        step = dt or self.t_final / (20 * self.transcription.scheme.intervals)

        def inputs(t: float) -> np.ndarray:
            return np.array([self._interpolated(n, min(t, self.t_final))[0][0] for n in names])

        traj = simulate(eqs, self.X[: eqs.nq, 0], self.X[eqs.nq :, 0], self.t_final,
                        SimulationOptions(dt=step, projection_interval=step), inputs=inputs if names else None)
        state_names = eqs.model.coordinate_names + eqs.model.speed_names
        sim = np.hstack([traj.q, traj.u])
        col = np.column_stack([self.polynomial(n, traj.t) for n in state_names])
        deviation = np.abs(sim - col)
        return {"max_state_deviation": float(deviation.max()), "final_state_deviation": float(deviation[-1].max()),
                "worst": state_names[int(deviation.max(axis=0).argmax())], "trajectory": traj}
