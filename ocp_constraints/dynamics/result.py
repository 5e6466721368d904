"""One result vocabulary (issue 12): every result answers the same questions in the same words.

Every result type (:class:`~ocp_constraints.dynamics.trajectory.Trajectory` from
``simulate``, :class:`~ocp_constraints.dynamics.inverse.InverseDynamicsResult`,
:class:`~ocp_constraints.ocp.solution.OCPSolution`, the gait and knee results) has

- ``success: bool`` and ``status: str`` (the solver's own word where there is one);
- ``sample(name) -> np.ndarray``: a named quantity at every sample (coordinates
  ``<body>.<coordinate>``, angle rates ``<body>.<angle>_dot``, speeds, multipliers
  ``<constraint>.lambda``, inputs, and what else the result holds); ``sample_names()``
  lists the names; an unknown name is a :class:`ModelError` that names it and the
  closest known names;
- ``loads() -> dict[str, np.ndarray]``: DESIGN.md's loads.csv columns, from the one
  place that makes them (:mod:`ocp_constraints.mechanics.load_columns`);
- ``load_about(joint, point) -> (F, M)``: a joint load moved to another material point
  (paper eq. 33), samples x 3 each.

Results without joint loads (the knee's static optimisation) raise a :class:`ModelError`
from ``loads()`` and ``load_about()`` that says so.
"""
from __future__ import annotations

import difflib

import numpy as np

from ..errors import ModelError
from ..mechanics.equations import SystemEquations
from ..mechanics.load_columns import load_about, load_columns


def unknown_name_message(name: str, names: list[str], what: str = "quantity", where: str = "this result") -> str:
    """``no <what> named '<name>' in <where>``, the closest known names, and what to do."""
    close = difflib.get_close_matches(name, names, n=5, cutoff=0.75)
    text = f"no {what} named '{name}' in {where}"
    text += f"; did you mean {', '.join(repr(c) for c in close)}?" if close else "."
    if what == "quantity" and name in ("t", "time"):
        text += " The sample times are the result's .t (s)."
    if what == "quantity" and ("@" in name or name.rsplit(".", 1)[-1][:2] in ("F_", "M_")):
        # a joint load asked of sample(): loads live in their own table (paper eq. 33 moves them)
        text += " Joint loads (F_c at X_C, M_c, power) are the columns of .loads(), e.g. .loads()['<joint>.F_x']."
    if len(names) <= 40:
        return text + f" Available: {sorted(names)}"
    return text + f" ({len(names)} names; list them with .sample_names())"


def state_columns(eqs: SystemEquations, q: np.ndarray, u: np.ndarray) -> dict[str, np.ndarray]:
    """``<body>.<coordinate>``, ``<body>.<angle>_dot`` (rad/s) and speeds at every sample (rows of ``q``, ``u``).

    The angle rates come from ``q' = N(q) u`` in one mapped evaluation over the samples.
    """
    m = eqs.model
    q = np.asarray(q, dtype=float).reshape(-1, eqs.nq)
    u = np.asarray(u, dtype=float).reshape(-1, eqs.nu)
    n = len(q)
    rates = np.asarray(eqs.coordinate_rates.map(n)(q.T, u.T)).T.reshape(n, eqs.nq) if n else np.zeros((0, eqs.nq))
    cols = {name: q[:, i] for i, name in enumerate(m.coordinate_names)}
    for i, name in enumerate(m.coordinate_names):
        if name.split(".")[-1] not in ("x", "y", "z"):
            cols[f"{name}_dot"] = rates[:, i]
    for i, name in enumerate(m.speed_names):
        cols[name] = u[:, i]
    return cols


class Result:
    """The common protocol. A subclass provides ``success``, ``status`` and :meth:`sample_columns`;
    it overrides :meth:`loads` and :meth:`load_about` where it has joint loads."""

    success: bool
    status: str

    def sample_columns(self) -> dict[str, np.ndarray]:
        """Every named quantity the result holds, at every sample."""
        raise NotImplementedError

    def sample_names(self) -> list[str]:
        return list(self.sample_columns())

    def sample(self, name: str) -> np.ndarray:
        """Values of a named quantity at every sample (see the module docstring for the names)."""
        cols = self.sample_columns()
        if name not in cols:
            # A position's rate is its speed (the mass centre's, fixed basis): the name a problem's initial and final
            # values accept ("block.x_dot") reads the speed's column rather than a copy of it.
            body, _, coordinate = name.removesuffix("_dot").rpartition(".")
            if name.endswith("_dot") and coordinate in ("x", "y", "z") and f"{body}.vbar_{coordinate}" in cols:
                return cols[f"{body}.vbar_{coordinate}"]
            raise ModelError(unknown_name_message(name, list(cols), where=f"this {type(self).__name__}"))
        return cols[name]

    def _no_loads(self, what: str) -> ModelError:
        return ModelError(f"{type(self).__name__}.{what}: this result has no joint loads (no states of bodies to "
                          "apply them to); its multipliers are sample('<constraint>.lambda')")

    def loads(self) -> dict[str, np.ndarray]:
        """loads.csv columns (DESIGN.md): ``<constraint>.lambda``; per joint ``F``, ``M``, ``point``, ``power``."""
        raise self._no_loads("loads()")

    def load_about(self, joint: str, point) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment of a joint load moved to the material ``point`` (eq. 33), samples x 3 each."""
        raise self._no_loads("load_about()")


class MechanicalResult(Result):
    """A result holding samples of ``(t, q, u, lambda, inputs)`` of one :class:`SystemEquations`.

    A subclass provides :meth:`mechanical_samples`; states, multipliers, inputs, loads and
    moved loads follow from it, the same way for every result type.
    """

    def mechanical_samples(self) -> tuple[SystemEquations, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(eqs, t, q, u, lam, inputs)``: arrays with one row per sample."""
        raise NotImplementedError

    def state_columns(self) -> dict[str, np.ndarray]:
        """``<body>.<coordinate>``, ``<body>.<coordinate>_dot`` (angle rates) and speeds."""
        eqs, _, q, u, _, _ = self.mechanical_samples()
        return state_columns(eqs, q, u)

    def multiplier_columns(self) -> dict[str, np.ndarray]:
        eqs, t, _, _, lam, _ = self.mechanical_samples()
        lam = np.asarray(lam, dtype=float).reshape(len(t), eqs.nc)
        return {f"{n}.lambda": lam[:, k] for k, n in enumerate(eqs.constraint_names)}

    def input_columns(self) -> dict[str, np.ndarray]:
        eqs, t, _, _, _, inputs = self.mechanical_samples()
        names = list(eqs.model.inputs)
        inputs = np.asarray(inputs, dtype=float).reshape(len(t), len(names))
        return {n: inputs[:, k] for k, n in enumerate(names)}

    def sample_columns(self) -> dict[str, np.ndarray]:
        return {**self.state_columns(), **self.multiplier_columns(), **self.input_columns()}

    def loads(self) -> dict[str, np.ndarray]:
        """Per scalar constraint ``<name>.lambda``; per joint ``F_x..z``, ``M_x..z``, ``point_x..z``, ``power``."""
        eqs, t, q, u, lam, _ = self.mechanical_samples()
        return load_columns(eqs, t, q, u, lam)

    def load_about(self, joint: str, point) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment of a joint load moved to another material point (eq. 33).

        ``joint``: a joint name, or ``<joint>@<body>`` for a two-body joint; ``point``: a
        model ``Point``. Returns arrays (samples x 3) in the fixed basis (N, N m).
        """
        eqs, t, q, u, lam, _ = self.mechanical_samples()
        return load_about(eqs, joint, point, t, q, u, lam)
