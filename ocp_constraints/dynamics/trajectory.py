"""A trajectory of states, multipliers and loads, addressed by name.

``traj.sample("disk.theta")``, ``traj.sample("shaft.drive.lambda")``,
``traj.loads()["shaft.M_z"]``, ``traj.load_about("shaft", point)``, ``traj.success``,
``traj.status``: the common vocabulary of :mod:`.result`; column names follow DESIGN.md's
results contract.
"""
from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..mechanics.equations import SystemEquations
from .result import MechanicalResult


class Trajectory(MechanicalResult):
    """Samples of ``t, q, u, u', lambda, inputs`` and the accumulated constraint work.

    ``success``/``status``: ``simulate`` sets True/``"completed"`` at the end of a run, and
    False/the reason on the partial trajectory of a run that stopped early
    (``SimulationError.partial``); a trajectory built from given samples takes them as
    arguments.
    """

    def __init__(self, eqs: SystemEquations, success: bool = True, status: str = "completed"):
        self.eqs = eqs
        self.success, self.status = success, status
        self._rows: dict[str, list] = {k: [] for k in ("t", "q", "u", "udot", "lam", "inputs", "work", "drift_q", "drift_u",
                                                       "applied_work")}

        self._columns: dict[str, np.ndarray] | None = None  # named columns, built on first use

    def append(self, t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work: float = 0.0) -> None:
        for key, value in zip(self._rows, (t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work)):
            self._rows[key].append(np.array(value, dtype=float, copy=True))
        self._columns = None

    def drop_incomplete_sample(self) -> None:
        """Keep only whole samples (after an interruption in the middle of :meth:`append`)."""
        n = min(len(v) for v in self._rows.values())
        for v in self._rows.values():
            del v[n:]
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

    @property
    def inputs(self) -> np.ndarray:
        """Actuator inputs (samples x inputs), in the order of ``model.inputs``."""
        return self._array("inputs").reshape(len(self), self.eqs.inputs.numel())

    # -- named access (the common vocabulary of dynamics/result.py) ---------------------
    def mechanical_samples(self):
        return self.eqs, self.t, self.q, self.u, self.lam, self.inputs

    def sample_columns(self) -> dict[str, np.ndarray]:
        """Coordinates, rates, speeds, multipliers and inputs by name (built once per length)."""
        if self._columns is None:
            self._columns = super().sample_columns()
        return self._columns

    def stop_early(self, reason: str) -> SimulationError:
        """Mark the run as stopped (``success`` False, ``status`` the reason); the error to raise."""
        self.success, self.status = False, reason
        return SimulationError(reason, partial=self)

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
