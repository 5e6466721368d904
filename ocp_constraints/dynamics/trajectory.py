"""A trajectory of states, multipliers and loads, addressed by name.

``traj.sample("disk.theta")``, ``traj.sample("shaft.drive.lambda")``,
``traj.loads()["shaft.M_z"]``: column names follow DESIGN.md's results contract.
"""
from __future__ import annotations

import numpy as np

from ..mechanics.equations import SystemEquations
from ..errors import ModelError


class Trajectory:
    """Samples of ``t, q, u, u', lambda, inputs`` and the accumulated constraint work."""

    def __init__(self, eqs: SystemEquations):
        self.eqs = eqs
        self._rows: dict[str, list] = {k: [] for k in ("t", "q", "u", "udot", "lam", "inputs", "work", "drift_q", "drift_u",
                                                       "applied_work")}

        self._columns: dict[str, np.ndarray] | None = None  # named columns, built on first use

    def append(self, t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work: float = 0.0) -> None:
        for key, value in zip(self._rows, (t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work)):
            self._rows[key].append(np.array(value, dtype=float, copy=True))
        self._columns = None

    def __len__(self) -> int:
        return len(self._rows["t"])

    def _array(self, key: str) -> np.ndarray:
        return np.asarray(self._rows[key])

    @property
    def t(self) -> np.ndarray:
        return self._array("t")

    @property
    def q(self) -> np.ndarray:
        return self._array("q").reshape(len(self), self.eqs.nq)

    @property
    def u(self) -> np.ndarray:
        return self._array("u").reshape(len(self), self.eqs.nu)

    @property
    def udot(self) -> np.ndarray:
        return self._array("udot").reshape(len(self), self.eqs.nu)

    @property
    def lam(self) -> np.ndarray:
        return self._array("lam").reshape(len(self), self.eqs.nc)

    @property
    def work(self) -> np.ndarray:
        """Work done by each constraint's load since the start (J), ``int -lambda e dt``."""
        return self._array("work").reshape(len(self), self.eqs.nc)

    @property
    def applied_work(self) -> np.ndarray:
        """Work done by the applied loads other than gravity since the start (J)."""
        return self._array("applied_work")

    @property
    def max_drift(self) -> tuple[float, float]:
        """Largest ``|phi|`` and ``|G u + e|`` found just before a projection (the drift the
        projection removed; the recorded states there are the projected ones)."""
        return float(self._array("drift_q").max(initial=0.0)), float(self._array("drift_u").max(initial=0.0))

    # -- named access -----------------------------------------------------------------
    def state_columns(self) -> dict[str, np.ndarray]:
        """``<body>.<coordinate>``, ``<body>.<coordinate>_dot`` (angle rates) and speeds."""
        m = self.eqs.model
        cols: dict[str, np.ndarray] = {}
        q, u = self.q, self.u
        # One mapped evaluation over all samples instead of a Python loop.
        rates = np.asarray(self.eqs.coordinate_rates.map(len(self))(q.T, u.T)).T.reshape(len(self), self.eqs.nq)
        for i, n in enumerate(m.coordinate_names):
            cols[n] = q[:, i]
        for i, n in enumerate(m.coordinate_names):
            if not n.split(".")[-1] in ("x", "y", "z"):
                cols[f"{n}_dot"] = rates[:, i]
        for i, n in enumerate(m.speed_names):
            cols[n] = u[:, i]
        return cols

    def multiplier_columns(self) -> dict[str, np.ndarray]:
        return {f"{n}.lambda": self.lam[:, k] for k, n in enumerate(self.eqs.constraint_names)}

    def input_columns(self) -> dict[str, np.ndarray]:
        inputs = self._array("inputs").reshape(len(self), self.eqs.inputs.numel())
        return {n: inputs[:, k] for k, n in enumerate(self.eqs.model.inputs)}

    def sample(self, name: str) -> np.ndarray:
        """Values of a named quantity at every sample (coordinate, rate, speed, multiplier or input)."""
        if self._columns is None:
            self._columns = {**self.state_columns(), **self.multiplier_columns(), **self.input_columns()}
        cols = self._columns
        if name not in cols:
            raise ModelError(f"no quantity named '{name}'; available: {sorted(cols)}")
        return cols[name]

    def loads(self) -> dict[str, np.ndarray]:
        """Per scalar constraint ``<name>.lambda``; per joint ``F_x..z``, ``M_x..z``, ``point_x..z``, ``power``."""
        cols = self.multiplier_columns()
        f = self.eqs.loads_function
        values = np.array([np.asarray(f(q, u, t, lam)).ravel() for q, u, t, lam in zip(self.q, self.u, self.t, self.lam)])
        k = 0
        for ch in self.eqs.load_channels:
            for quantity in ("F", "M", "point"):
                for axis in "xyz":
                    cols[f"{ch.prefix}.{quantity}_{axis}"] = values[:, k]
                    k += 1
            cols[f"{ch.prefix}.power"] = values[:, k]
            k += 1
        return cols

    def load_about(self, channel: str, point) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment of a joint load moved to another material point (eq. 33).

        Returns arrays (samples x 3) in the fixed basis; ``point`` is a model ``Point``.
        """
        f = self.eqs.load_about_function(channel, point)
        out = [f(q, u, t, lam) for q, u, t, lam in zip(self.q, self.u, self.t, self.lam)]
        return (np.array([np.asarray(F).ravel() for F, _ in out]), np.array([np.asarray(M).ravel() for _, M in out]))

    def energy(self) -> tuple[np.ndarray, np.ndarray]:
        """Kinetic and gravitational potential energy at every sample (J)."""
        f = self.eqs.energy_function
        TU = np.array([[float(v) for v in f(q, u)] for q, u in zip(self.q, self.u)])
        return TU[:, 0], TU[:, 1]

    def residuals(self) -> tuple[float, float]:
        """Largest position-level ``|phi|`` and velocity-level ``|G u + e|`` residuals,
        including those just before each projection."""
        f = self.eqs.constraint_functions
        pos, vel = self.max_drift  # at projections, the residuals before them
        inputs = self._array("inputs").reshape(len(self), self.eqs.inputs.numel())
        for q, u, t, w in zip(self.q, self.u, self.t, inputs):
            _, _, phi, pi, _ = f(q, u, t, w)
            pos = max(pos, float(np.abs(np.asarray(phi)).max(initial=0.0)))
            vel = max(vel, float(np.abs(np.asarray(pi)).max(initial=0.0)))
        return pos, vel
