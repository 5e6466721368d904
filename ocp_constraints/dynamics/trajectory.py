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
from ..mechanics.fast_eval import Buffered
from .result import MechanicalResult


_KEYS = ("t", "q", "u", "udot", "lam", "inputs", "work", "drift_q", "drift_u", "applied_work")
_SCALARS = ("t", "drift_q", "drift_u", "applied_work")


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
        # Per quantity a list of blocks (samples x values): ``simulate`` adds a whole segment at once
        # (one array per quantity, not one per sample: 10 small arrays a sample cost ~12 ms per 1,000).
        self._rows: dict[str, list[np.ndarray]] = {k: [] for k in _KEYS}
        self._columns: dict[str, np.ndarray] | None = None  # named columns, built on first use

    def append(self, t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work: float = 0.0) -> None:
        """One sample."""
        values = (t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work)
        self.extend(*(np.asarray(v, dtype=float).reshape(1, -1) for v in values))

    def extend(self, t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work) -> None:
        """Samples in rows: ``t``, ``drift_q``, ``drift_u``, ``applied_work`` of length m (or m x 1),
        the others m x (their size). The arrays are copied."""
        m = len(np.atleast_1d(t))
        if not m:
            return
        blocks = [np.array(v, dtype=float, copy=True).reshape(m, -1) for v in
                  (t, q, u, udot, lam, inputs, work, drift_q, drift_u, applied_work)]
        for key, block in zip(_KEYS, blocks):
            self._rows[key].append(block)
        self._columns = None

    def drop_incomplete_sample(self) -> None:
        """Keep only whole samples (after an interruption in the middle of :meth:`extend`)."""
        n = min(self._count(k) for k in _KEYS)
        for k in _KEYS:
            if self._count(k) > n:
                self._rows[k] = [self._joined(k)[:n]]
        self._columns = None

    def _count(self, key: str) -> int:
        return sum(len(b) for b in self._rows[key])

    def _joined(self, key: str) -> np.ndarray:
        """The blocks of ``key`` as one array (kept joined for the next call)."""
        blocks = self._rows[key]
        if len(blocks) != 1:
            width = blocks[0].shape[1] if blocks else 0
            blocks[:] = [np.concatenate(blocks) if blocks else np.zeros((0, width))]
        return blocks[0]

    def __len__(self) -> int:
        return self._count("t")

    def _array(self, key: str) -> np.ndarray:
        a = self._joined(key)
        return (a[:, 0] if key in _SCALARS else a).copy()   # a fresh array, as a caller may write to it

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
        T, U = mapped(self.eqs.energy_function, self.q, self.u)
        return T, U

    def residuals(self) -> tuple[float, float]:
        """Largest position-level ``|phi|`` and velocity-level ``|G u + e|`` residuals,
        including those just before each projection."""
        pos, vel = self.max_drift  # at projections, the residuals before them
        if not len(self):
            return pos, vel
        _, _, phi, pi, _ = mapped(self.eqs.constraint_functions, self.q, self.u, self.t, self.inputs)
        return max(pos, float(np.abs(phi).max(initial=0.0))), max(vel, float(np.abs(pi).max(initial=0.0)))


def mapped(f, *columns) -> list[np.ndarray]:
    """``f`` evaluated on every sample (rows of ``columns``) in one mapped call, not one call per
    sample. Returns, per output, samples x size (a scalar output: one value per sample); only
    column-vector outputs are meaningful."""
    n = len(columns[0])
    out = Buffered(f.map(n))(*[np.asarray(c, float).reshape(n, -1).T for c in columns])
    rows = [o.reshape(-1, n, order="F").T for o in out]
    return [r[:, 0] if r.shape[1] == 1 else r for r in rows]
