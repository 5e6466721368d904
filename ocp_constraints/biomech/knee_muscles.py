"""Muscle-tendon paths of the JW model as smooth functions of the coordinates (issue 7, step 2).

OpenSim computes a muscle's path through via points and over wrap surfaces (cylinders,
ellipsoids); the knee extensors wrap over the femoral component and the patella, the
gastrocnemii over the condyles. Instead of re-implementing wrapping, the force path
``L(q)`` of every right-leg muscle is fitted, once, by a polynomial in the coordinates it
spans, to OpenSim's own path lengths and moment arms (``computeMomentArm``) over the range
of motion (:mod:`.knee_path_fits`; ``scripts/knee_muscle_fits.py``: OpenSim runs in its own
process, the fit is stored in ``ocp_constraints/biomech/data/jw_knee_muscle_paths.json``).
Moment arms follow by differentiation, ``r_c = -dL/dq_c`` (virtual work: a tension ``F``
gives the generalized force ``F r_c``, paper eqs. 35-41), for the primary coordinates (rad -> m) and for the
five locked knee directions (``knee_adduction``, ``knee_rotation`` in m, ``knee_tx``,
``knee_ty``, ``knee_tz`` dimensionless: the share of the tension along that axis).

The patella follows the model's CoordinateCouplerConstraint ``patfem_flexion =
knee_flexion + 1.57``; the fitted lengths include it, so the knee-flexion moment arms
of the quadriceps are those of the coupled model (as OpenSim's ``computeMomentArm``).

Basis (scaled coordinates ``x = (q - centre) / half_range``): all monomials of the
spanned primary coordinates up to total degree ``DEGREE``, each secondary coordinate
times the monomials of degree <= ``SECONDARY_DEGREE`` of the primaries, and the squares
of the secondaries.
"""
from __future__ import annotations

import itertools
import json
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from ..errors import MuscleDataError

DATA_FILE = Path(__file__).resolve().parent / "data" / "jw_knee_muscle_paths.json"
PRIMARY = ["hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "ankle_angle", "subtalar_angle"]
SECONDARY = ["knee_adduction", "knee_rotation", "knee_tx", "knee_ty", "knee_tz"]
DEGREE = {1: 7, 2: 6, 3: 5, 4: 5}
SECONDARY_DEGREE = 3


def exponents(n_primary: int, n_secondary: int) -> np.ndarray:
    """Exponent rows of the basis (columns: primaries, then secondaries)."""
    deg = DEGREE.get(n_primary, 4)
    rows = []
    for total in range(deg + 1):
        for e in itertools.product(range(total + 1), repeat=n_primary):
            if sum(e) == total:
                rows.append(list(e) + [0] * n_secondary)
    for j in range(n_secondary):
        for total in range(SECONDARY_DEGREE + 1):
            for e in itertools.product(range(total + 1), repeat=n_primary):
                if sum(e) == total:
                    s = [0] * n_secondary
                    s[j] = 1
                    rows.append(list(e) + s)
        s = [0] * n_secondary
        s[j] = 2
        rows.append([0] * n_primary + s)
    return np.array(rows, dtype=int).reshape(-1, n_primary + n_secondary)


def basis(x, E: np.ndarray):
    """Monomials ``prod_i x_i^E[k, i]`` for numeric ``x`` (samples x vars) or a CasADi column."""
    if isinstance(x, (ca.SX, ca.MX)):
        E = np.asarray(E, dtype=int)
        out = ca.DM.ones(E.shape[0])
        for i in range(E.shape[1]):          # column-wise: a few vector operations per variable
            top = int(E[:, i].max(initial=0))
            if top:
                powers = ca.vertcat(1, *[x[i] ** k for k in range(1, top + 1)])
                out = out * powers[E[:, i].tolist()]
        return out if isinstance(out, (ca.SX, ca.MX)) else ca.SX(out)
    x = np.atleast_2d(x)
    return np.prod(x[:, None, :] ** E[None, :, :], axis=2)


@dataclass
class MuscleParameters:
    """Hill-model parameters read from the .osim file (N, m, rad)."""

    max_isometric_force: float
    optimal_fiber_length: float
    tendon_slack_length: float
    pennation_angle: float


def muscle_parameters(osim_path, names: list[str]) -> dict[str, MuscleParameters]:
    """``max_isometric_force`` etc. of the named muscles, from the model file."""
    try:
        from .osim_model import model_xml

        root = model_xml(osim_path)        # parsed once per process with the inverse dynamics
    except (OSError, ET.ParseError) as exc:
        raise MuscleDataError(f"{osim_path}: cannot read the model: {exc}") from exc
    found = {}
    for elem in root.iter():
        name = elem.get("name")
        if name in names and elem.find("max_isometric_force") is not None and re.search("Muscle", elem.tag):
            def num(tag, default=0.0):
                t = elem.findtext(tag)
                return float(t) if t is not None else default
            found[name] = MuscleParameters(num("max_isometric_force"), num("optimal_fiber_length"),
                                           num("tendon_slack_length"), num("pennation_angle_at_optimal"))
    missing = [n for n in names if n not in found]
    if missing:
        raise MuscleDataError(f"{osim_path}: muscle(s) {missing} of the path data are not in the model")
    return found


class MusclePaths:
    """Fitted path lengths ``L(q)`` (m) and moment arms ``-dL/dq`` (paper eqs. 35-41), as CasADi functions
    and, for the moment arms at given poses, in NumPy (:meth:`moment_arms_at`).

    ``coordinates`` is :data:`PRIMARY` + :data:`SECONDARY` (rad, m; knee_ty absolute, m).

    Two lengths per muscle. ``length`` is the path along which the tension acts (its
    gradient gives the moment arms); ``unit_length`` is the length of the muscle-tendon
    unit, the one the model's ``optimal_fiber_length`` and ``tendon_slack_length`` refer
    to (fibre kinematics of the Hill model). They differ for the quadriceps of the JW
    model (``units``): their force paths run over the patella to the tibia (the patellar
    ligament is part of the path, so that the knee moment arm is right), while their
    muscle-tendon units end on the patella (the model's ``<name>_withreallength`` twins,
    about 0.1 m shorter). For every other muscle the two are the same.
    """

    def __init__(self, path=DATA_FILE):
        try:
            data = json.loads(Path(path).read_text())
        except (OSError, ValueError) as exc:
            raise MuscleDataError(f"{path}: cannot read the muscle-path data: {exc}") from exc
        self.path, self.data = str(path), data
        self.muscles: list[str] = list(data["fits"])
        self.coordinates = PRIMARY + SECONDARY
        units = data.get("unit_fits", {})
        self.units: list[str] = [m for m in self.muscles if m in units]
        self._functions: dict[str, ca.Function] | None = None

    # The CasADi functions are built on first use only: the static optimisation needs the moment
    # arms at the frames alone, which moment_arms_at evaluates in NumPy (0.25 s of CPU saved per run).
    def _casadi(self) -> dict[str, ca.Function]:
        if self._functions is None:
            q = ca.SX.sym("q", len(self.coordinates))

            def fitted(f):
                idx = [self.coordinates.index(c) for c in f["coordinates"]]
                z = (q[idx] - ca.DM(f["centre"])) / ca.DM(f["half_range"])
                return ca.dot(ca.DM(f["coefficients"]), basis(z, np.asarray(f["exponents"], dtype=int)))

            units = self.data.get("unit_fits", {})
            L = ca.vertcat(*[fitted(self.data["fits"][m]) for m in self.muscles])
            U = ca.vertcat(*[fitted(units[m]) if m in units else L[i] for i, m in enumerate(self.muscles)])
            self._functions = {
                "length": ca.Function("muscle_length", [q], [L], ["q"], ["L"]),
                "moment_arms": ca.Function("moment_arms", [q], [-ca.jacobian(L, q)], ["q"], ["R"]),
                "unit_length": ca.Function("unit_length", [q], [U], ["q"], ["L"]),
                "unit_jacobian": ca.Function("unit_jacobian", [q], [ca.jacobian(U, q)], ["q"], ["J"])}
        return self._functions

    @property
    def length(self) -> ca.Function:
        """``q -> L`` (m), the force paths (CasADi)."""
        return self._casadi()["length"]

    @property
    def moment_arms(self) -> ca.Function:
        """``q -> R = -dL/dq`` (muscles x coordinates; m, or the share of the tension for a translation)."""
        return self._casadi()["moment_arms"]

    @property
    def unit_length(self) -> ca.Function:
        """``q -> L`` (m), the muscle-tendon units (see the class docstring)."""
        return self._casadi()["unit_length"]

    @property
    def unit_jacobian(self) -> ca.Function:
        """``q -> dL_unit/dq``."""
        return self._casadi()["unit_jacobian"]

    def moment_arms_at(self, Q: np.ndarray) -> np.ndarray:
        """``R = -dL/dq`` at many poses in NumPy: ``Q`` (frames x :attr:`coordinates`) -> frames x
        coordinates x muscles. The derivative of each monomial of the fit is written out,
        ``d/dz_j prod_i z_i^e_i = e_j z_j^(e_j - 1) prod_(i != j) z_i^e_i``, and ``dz_j/dq_j = 1/half_j``."""
        Q = np.atleast_2d(np.asarray(Q, float))
        out = np.zeros((Q.shape[0], len(self.coordinates), len(self.muscles)))
        for m, name in enumerate(self.muscles):
            f = self.data["fits"][name]
            idx = [self.coordinates.index(c) for c in f["coordinates"]]
            E = np.asarray(f["exponents"], dtype=int)
            coef = np.asarray(f["coefficients"], float)
            z = (Q[:, idx] - np.asarray(f["centre"])) / np.asarray(f["half_range"])
            top = int(E.max(initial=0))
            powers = z[:, :, None] ** np.arange(top + 1)           # frames x vars x power
            half = np.asarray(f["half_range"], float)
            for j in range(len(idx)):
                use = E[:, j] > 0                          # the other monomials do not depend on z_j
                Ej = E[use].copy()
                Ej[:, j] -= 1
                mono = np.ones((Q.shape[0], int(use.sum())))
                for i in range(len(idx)):                  # prod_i z_i^(e_ki - delta_ij)
                    mono *= powers[:, i, Ej[:, i]]
                out[:, idx[j], m] = -(mono @ (coef[use] * E[use, j])) / half[j]
        return out

    def crossing(self, coordinate: str) -> list[str]:
        """Muscles whose path spans ``coordinate``."""
        return [m for m in self.muscles if coordinate in self.data["fits"][m]["coordinates"]]

    def q_vector(self, values: dict[str, float]) -> np.ndarray:
        """Coordinate vector from a dict (missing: 0; knee_ty: the model default)."""
        q = np.zeros(len(self.coordinates))
        q[self.coordinates.index("knee_ty")] = self.data["knee_ty"]
        for k, v in values.items():
            q[self.coordinates.index(k)] = v
        return q
