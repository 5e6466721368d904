"""Rigid bodies and their material points as CasADi expressions.

A body's coordinates are the position of its center of mass ``xbar`` and its rotation
parameters (three Euler angles or a unit quaternion); its speeds are ``vbar`` and the
angular velocity ``omega``, both in the fixed basis (DESIGN.md). A material point
``X_C`` is given by its offset ``r`` from the center of mass in the body basis, so
``x_C = xbar + Q r`` (paper eq. 7) and ``v_C = vbar + omega x (x_C - xbar)``
(paper eq. 8).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..errors import ModelError
from .rotations import EulerSequence, Rotation, UnitQuaternion, rotation_from_name

POSITION_NAMES = ("x", "y", "z")
SPEED_NAMES = ("vbar_x", "vbar_y", "vbar_z", "omega_x", "omega_y", "omega_z")


def _finite_array(value, shape, what: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{what} must be numeric, got {value!r}") from exc
    if a.shape != shape:
        raise ModelError(f"{what} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{what} has a non-finite entry: {a.tolist()}")
    return a


@dataclass(eq=False)
class Point:
    """A material point of a body (or the ground, where ``body`` is None).

    ``offset`` is the body-basis offset from the center of mass; it may depend on the
    body's coordinates (e.g. the instantaneous contact point of a disk). ``v`` is the
    symbol a constraint expression uses for the velocity of the material point that is
    at ``X_C`` at this instant.
    """

    body: "Body"
    name: str
    offset: ca.SX
    position: ca.SX
    v: ca.SX

    @property
    def label(self) -> str:
        return f"{self.body.name}.{self.name}"

    def velocity(self) -> ca.SX:
        """``v_C = vbar + omega x (x_C - xbar)`` in terms of the body's speeds (eq. 8)."""
        b = self.body
        return b.vbar + ca.cross(b.omega, self.position - b.xbar)


@dataclass(eq=False)
class Body:
    """A rigid body: mass, inertia about the center of mass in the body basis, rotation.

    Parameters
    ----------
    name
        Used in every column name (``<body>.<coordinate>``).
    mass
        kg, positive.
    inertia
        3x3 symmetric inertia tensor (principal moments non-negative, triangle inequality) about the center of mass, in the
        body basis ``e_i`` (kg m^2). Products of inertia are allowed.
    rotation
        ``"313"``, ``"321"`` (any Euler sequence) or ``"quaternion"``.
    check_inertia
        Keyword only. ``True`` (default): the inertia must be a physical rigid body's
        (principal moments non-negative, each at most the sum of the other two).
        ``False``: the triangle inequality is not enforced (symmetry and non-negative
        principal moments still are), for imported models that carry such inertias
        (OpenSim accepts them); ``inertia_warning`` then says what was accepted.
    """

    name: str
    mass: float
    inertia: np.ndarray
    rotation: Rotation = field(default_factory=lambda: EulerSequence("313"))
    points: dict[str, Point] = field(default_factory=dict)
    check_inertia: bool = field(default=True, kw_only=True)
    inertia_warning: str | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        if not self.name or not str(self.name).replace("_", "").isalnum():
            raise ModelError(f"body name {self.name!r} must be a non-empty identifier")
        m = float(_finite_array(self.mass, (), f"body '{self.name}': mass"))
        if m <= 0:
            raise ModelError(f"body '{self.name}': mass must be positive, got {m}")
        self.mass = m
        J = _finite_array(self.inertia, (3, 3), f"body '{self.name}': inertia")
        if not np.allclose(J, J.T, rtol=0, atol=1e-12 * max(1.0, np.abs(J).max())):
            raise ModelError(f"body '{self.name}': inertia tensor must be symmetric, got {J.tolist()}")
        principal = np.linalg.eigvalsh(J)
        scale = max(principal.max(), 1e-300)
        # A thin rod has a zero principal moment; anything else must be a physical tensor.
        negative = principal.min() < -1e-12 * scale or principal.max() <= 0
        triangle = principal.sum() - 2 * principal.max() < -1e-12 * scale
        if negative or (triangle and self.check_inertia):
            raise ModelError(
                f"body '{self.name}': inertia tensor {J.tolist()} is not physical: principal moments "
                f"{principal.tolist()} must be non-negative and each at most the sum of the other two"
                + ("" if negative else " (Body(..., check_inertia=False) accepts it, e.g. for an imported model)")
            )
        if triangle:
            self.inertia_warning = (
                f"body '{self.name}': principal moments of inertia {principal.tolist()} break the triangle "
                "inequality (not a physical rigid body); used as given (check_inertia=False)"
            )
        self.inertia = J
        self.rotation = rotation_from_name(self.rotation)
        n_rot = self.rotation.n_parameters
        self.q = ca.SX.sym(f"{self.name}.q", 3 + n_rot)
        self.vbar = ca.SX.sym(f"{self.name}.vbar", 3)
        self.omega = ca.SX.sym(f"{self.name}.omega", 3)
        self.xbar = self.q[0:3]
        self.rotation_parameters = self.q[3:]
        self.Q = self.rotation.rotation(self.rotation_parameters)
        com = Point(self, "com", ca.SX.zeros(3, 1), self.xbar, self.vbar)
        self.points = {"com": com}

    # -- names -----------------------------------------------------------------
    @property
    def coordinate_names(self) -> list[str]:
        return [f"{self.name}.{c}" for c in POSITION_NAMES + self.rotation.parameter_names]

    @property
    def speed_names(self) -> list[str]:
        return [f"{self.name}.{s}" for s in SPEED_NAMES]

    @property
    def u(self) -> ca.SX:
        """The body's speeds ``(vbar, omega)``."""
        return ca.vertcat(self.vbar, self.omega)

    # -- geometry --------------------------------------------------------------
    @property
    def com(self) -> Point:
        return self.points["com"]

    def e(self, k: int) -> ca.SX:
        """Body basis vector ``e_k = Q E_k`` in the fixed basis."""
        return self.Q[:, k - 1]

    def point(self, name: str, offset) -> Point:
        """Declare a material point at body-basis ``offset`` from the center of mass (m).

        ``offset`` may be numbers or an expression of this body's coordinates.
        """
        if name in self.points:
            raise ModelError(f"body '{self.name}' already has a point named '{name}'")
        if isinstance(offset, (ca.SX, ca.MX)):
            r = ca.SX(offset) if isinstance(offset, ca.SX) else None
            if r is None or r.shape != (3, 1):
                raise ModelError(f"point '{self.name}.{name}': offset must be a 3x1 SX expression")
            foreign = [s for s in ca.symvar(r) if not ca.depends_on(self.q, s)]
            if foreign:
                names = ", ".join(s.name() for s in foreign)
                raise ModelError(
                    f"point '{self.name}.{name}': offset may depend only on the coordinates of "
                    f"body '{self.name}', but it uses {names}"
                )
        else:
            r = ca.SX(ca.DM(_finite_array(offset, (3,), f"point '{self.name}.{name}': offset")))
        p = Point(self, name, r, self.xbar + self.Q @ r, ca.SX.sym(f"{self.name}.{name}.v", 3))
        self.points[name] = p
        return p

    # -- Euler bases (eqs. 9-12) -------------------------------------------------
    def _euler(self) -> EulerSequence:
        if not isinstance(self.rotation, EulerSequence):
            raise ModelError(
                f"body '{self.name}' uses a {type(self.rotation).__name__}; the Euler basis "
                "exists only for Euler-angle bodies"
            )
        return self.rotation

    def euler_basis(self) -> list[ca.SX]:
        """``g_1, g_2, g_3`` in the fixed basis (paper eq. 10)."""
        return self._euler().euler_basis(self.rotation_parameters)

    def dual_euler_basis(self) -> list[ca.SX]:
        """``g^1, g^2, g^3`` in the fixed basis (paper eq. 11)."""
        return self._euler().dual_euler_basis(self.rotation_parameters)

    # -- kinematics --------------------------------------------------------------
    def coordinate_rates(self) -> ca.SX:
        """``q' = N(q) u``: ``xbar' = vbar``, angle rates ``omega . g^i`` or quaternion rates."""
        return ca.vertcat(self.vbar, self.rotation.rates(self.rotation_parameters, self.omega))

    def speeds_from_rates_matrix(self) -> ca.SX:
        """``B(q)`` with ``u = B(q) q'`` (``omega = [g_1 g_2 g_3] (angle rates)``)."""
        R = self.rotation.rates_to_omega_matrix(self.rotation_parameters)
        return ca.diagcat(ca.SX.eye(3), R)

    def inertia_fixed(self) -> ca.SX:
        """Inertia tensor about the center of mass in the fixed basis, ``Q J Q^T``."""
        return self.Q @ ca.DM(self.inertia) @ self.Q.T

    def kinetic_energy(self) -> ca.SX:
        J = self.inertia_fixed()
        return 0.5 * self.mass * ca.dot(self.vbar, self.vbar) + 0.5 * ca.dot(self.omega, J @ self.omega)

    def check_singularity(self, q_body, where: str) -> None:
        """Raise if this body's rotation parameters are (near) singular at ``q_body``."""
        self.rotation.check_singularity(np.asarray(q_body, dtype=float)[3:], f"body '{self.name}' {where}")


__all__ = ["Body", "Point", "UnitQuaternion", "EulerSequence"]
