"""The result of an optimal-control solve, queried by name.

``sol.sample("rod.psi")``, ``sol.loads()["hinge.M_z"]``, ``sol.interpolate("motor", t)``;
``sol.success``, ``sol.status``, ``sol.iterations``, ``sol.objective``, wall times, and
the constraint residuals at every collocation point. The samples are the collocation
points (mesh points and interior points, in time order).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import OcpConstraintsError
from .solution import Trajectory


@dataclass
class OCPSolution:
    """States, derivatives, multipliers and inputs at the collocation points, and solver stats."""

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

    @classmethod
    def from_vector(cls, tr, w: np.ndarray, stats: dict, objective: float, wall_time: dict) -> "OCPSolution":
        lay = tr.layout
        X, D, L, W, _, T = (np.asarray(a) for a in lay.split(w))
        t_final = float(T[0]) if lay.free_time else float(tr.problem.t_final)
        t = tr.fractions * t_final
        eqs = tr.eqs
        traj = Trajectory(eqs)
        for i in range(lay.n_points):
            traj.append(t[i], X[: eqs.nq, i], X[eqs.nq :, i], D[eqs.nq :, i], L[:, i], W[:, i], np.zeros(eqs.nc), 0.0, 0.0)
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
    def sample(self, name: str) -> np.ndarray:
        """A coordinate, rate, speed, multiplier (``<constraint>.lambda``) or input at every point."""
        inputs = list(self.transcription.problem.model.inputs)
        if name in inputs:
            return self.inputs[inputs.index(name)]
        return self.trajectory.sample(name)

    def loads(self) -> dict[str, np.ndarray]:
        """Per constraint ``lambda`` and per joint ``F``, ``M``, ``point``, ``power`` (DESIGN.md)."""
        return self.trajectory.loads()

    def interpolate(self, name: str, times) -> np.ndarray:
        """A named quantity between points through each interval's collocation polynomial.

        Radau: the Lagrange polynomial through the interval's points; trapezoidal and
        Hermite-Simpson: the same construction through their points (the state
        polynomials of those schemes have the same degree).
        """
        values = self.sample(name)
        scheme = self.transcription.scheme
        p = len(scheme.tau)
        mesh = scheme.mesh_fractions * self.t_final
        times = np.atleast_1d(np.asarray(times, dtype=float))
        k = np.clip(np.searchsorted(mesh, times, side="right") - 1, 0, scheme.intervals - 1)
        out = np.empty_like(times)
        for n, (tk, kk) in enumerate(zip(times, k)):
            idx = np.arange(kk * (p - 1), kk * (p - 1) + p)
            ts, vs = self.t[idx], values[idx]
            out[n] = sum(vs[j] * np.prod([(tk - ts[s]) / (ts[j] - ts[s]) for s in range(p) if s != j]) for j in range(p))
        return out


class OCPSolveError(OcpConstraintsError, RuntimeError):
    """IPOPT did not converge; ``solution`` holds the last iterate (``success`` False)."""

    def __init__(self, message: str, solution: OCPSolution):
        super().__init__(message)
        self.solution = solution
