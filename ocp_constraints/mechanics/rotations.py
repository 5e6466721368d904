"""Rotation parameterizations: Euler sequences and unit quaternions.

Conventions (DESIGN.md): fixed basis ``E1, E2, E3``; body basis ``e_i = Q E_i``.
An Euler sequence ``"ijk"`` with angles ``(a1, a2, a3)`` means
``Q = R_i(a1) R_j(a2) R_k(a3)``; ``"313"`` is ``(psi, theta, phi)`` with
``Q = R3(psi) R1(theta) R3(phi)`` and ``"321"`` is ``Q = R3(psi) R2(theta) R1(phi)``.

All functions take and return CasADi expressions (SX, MX or DM), so the same code
builds symbolic graphs and evaluates numbers.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..errors import ModelError, SingularConfigurationError

#: Angle names used for every Euler sequence (paper: psi, theta, phi).
EULER_ANGLE_NAMES = ("psi", "theta", "phi")
QUATERNION_NAMES = ("qw", "qx", "qy", "qz")


def unit_vector(k: int) -> ca.DM:
    """Fixed basis vector ``E_k`` (k = 1, 2, 3) as a 3x1 column."""
    e = ca.DM.zeros(3, 1)
    e[k - 1] = 1
    return e


def elementary_rotation(axis: int, angle) -> ca.SX:
    """Rotation tensor ``R_k(angle)`` about fixed axis ``E_k`` (right-handed)."""
    c, s = ca.cos(angle), ca.sin(angle)
    one, zero = 1, 0
    if axis == 1:
        rows = [[one, zero, zero], [zero, c, -s], [zero, s, c]]
    elif axis == 2:
        rows = [[c, zero, s], [zero, one, zero], [-s, zero, c]]
    elif axis == 3:
        rows = [[c, -s, zero], [s, c, zero], [zero, zero, one]]
    else:
        raise ValueError(f"rotation axis must be 1, 2 or 3, got {axis!r}")
    return ca.vertcat(*[ca.horzcat(*r) for r in rows])


@dataclass(frozen=True)
class EulerSequence:
    """A proper (``"313"``, ``"121"``, ...) or Tait-Bryan (``"321"``, ...) Euler sequence.

    Parameters
    ----------
    axes
        Three digits naming the successive rotation axes, e.g. ``"313"``.
    singularity_tolerance
        The sequence is reported singular where ``|g_1 . (g_2 x g_3)|`` (the volume of
        the Euler basis: ``|sin a2|`` for proper, ``|cos a2|`` for Tait-Bryan
        sequences) falls below this value.
    """

    axes: str
    singularity_tolerance: float = 1e-3

    def __post_init__(self) -> None:
        a = self.axes
        if len(a) != 3 or any(c not in "123" for c in a) or a[0] == a[1] or a[1] == a[2]:
            raise ModelError(
                f"Euler sequence {a!r} is not valid: give three axes from 1, 2, 3 with no "
                "axis repeated twice in a row, e.g. '313' or '321'"
            )

    @property
    def n_parameters(self) -> int:
        return 3

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return EULER_ANGLE_NAMES

    @property
    def is_proper(self) -> bool:
        """True for a proper Euler sequence (first and last axes equal)."""
        return self.axes[0] == self.axes[2]

    def _axis(self, n: int) -> int:
        return int(self.axes[n])

    def rotation(self, angles) -> ca.SX:
        """Rotation tensor ``Q = R_i(a1) R_j(a2) R_k(a3)``."""
        return (
            elementary_rotation(self._axis(0), angles[0])
            @ elementary_rotation(self._axis(1), angles[1])
            @ elementary_rotation(self._axis(2), angles[2])
        )

    def euler_basis(self, angles) -> list:
        """Euler basis ``g_1, g_2, g_3`` in the fixed basis (paper eq. 10).

        ``g_1 = E_i``, ``g_2 = R_i(a1) E_j``, ``g_3 = R_i(a1) R_j(a2) E_k``, so that
        ``omega = a1' g_1 + a2' g_2 + a3' g_3`` (paper eq. 9).
        """
        r1 = elementary_rotation(self._axis(0), angles[0])
        r12 = r1 @ elementary_rotation(self._axis(1), angles[1])
        return [
            unit_vector(self._axis(0)),
            r1 @ unit_vector(self._axis(1)),
            r12 @ unit_vector(self._axis(2)),
        ]

    def basis_volume(self, angles):
        """``g = g_1 . (g_2 x g_3)``: zero exactly where the Euler basis is singular.

        Paper: ``g = (g_1 x g_2) . g_3 = -sin(theta)`` for 3-1-3 angles.
        """
        g1, g2, g3 = self.euler_basis(angles)
        return ca.dot(g1, ca.cross(g2, g3))

    def dual_euler_basis(self, angles) -> list:
        """Dual Euler basis ``g^1, g^2, g^3`` with ``g^i . g_j = delta^i_j`` (paper eq. 11).

        ``omega . g^i`` is the i-th angle rate (paper eq. 12). Not defined where
        :meth:`basis_volume` vanishes; see :meth:`check_singularity`.
        """
        g1, g2, g3 = self.euler_basis(angles)
        g = ca.dot(g1, ca.cross(g2, g3))
        return [ca.cross(g2, g3) / g, ca.cross(g3, g1) / g, ca.cross(g1, g2) / g]

    def angular_velocity(self, angles, rates) -> ca.SX:
        """``omega = sum_i rate_i g_i`` (paper eq. 9)."""
        g = self.euler_basis(angles)
        return g[0] * rates[0] + g[1] * rates[1] + g[2] * rates[2]

    def rates(self, angles, omega) -> ca.SX:
        """Angle rates ``omega . g^i`` (paper eq. 12)."""
        return ca.vertcat(*[ca.dot(omega, gi) for gi in self.dual_euler_basis(angles)])

    def rates_to_omega_matrix(self, angles) -> ca.SX:
        """Matrix ``[g_1 g_2 g_3]`` mapping angle rates to ``omega``."""
        return ca.horzcat(*self.euler_basis(angles))

    def singular_angle_hint(self) -> str:
        """Plain-language description of where this sequence is singular."""
        if self.is_proper:
            return "the second angle (theta) is 0 or pi"
        return "the second angle (theta) is +pi/2 or -pi/2"

    def check_singularity(self, angles, where: str) -> None:
        """Raise :class:`SingularConfigurationError` if ``angles`` are too close to a singularity.

        ``where`` names the body (and time) in the message.
        """
        volume = float(abs(self.basis_volume(ca.DM(np.asarray(angles, dtype=float)))))
        if volume < self.singularity_tolerance:
            raise SingularConfigurationError(
                f"{where}: Euler sequence '{self.axes}' is singular where "
                f"{self.singular_angle_hint()}; here theta = {float(angles[1]):.6g} rad and "
                f"|g_1 . (g_2 x g_3)| = {volume:.3g} (tolerance {self.singularity_tolerance:g}), "
                "so the dual Euler basis and the angle rates are not defined. "
                "Use rotation='quaternion' for this body, or an Euler sequence whose "
                "singularity the motion avoids."
            )


@dataclass(frozen=True)
class UnitQuaternion:
    """Singularity-free rotation parameters ``(qw, qx, qy, qz)``.

    ``Q`` is built so that it stays orthogonal for any non-zero ``q`` (it divides by
    ``q . q``); the unit norm is kept by projection in the simulator.
    """

    @property
    def n_parameters(self) -> int:
        return 4

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return QUATERNION_NAMES

    def rotation(self, q) -> ca.SX:
        w, x, y, z = q[0], q[1], q[2], q[3]
        s = 2 / (w * w + x * x + y * y + z * z)
        return ca.vertcat(
            ca.horzcat(1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)),
            ca.horzcat(s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)),
            ca.horzcat(s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)),
        )

    def rates(self, q, omega) -> ca.SX:
        """``q' = 1/2 (0, omega) (x) q`` with ``omega`` in the fixed basis."""
        w, v = q[0], q[1:4]
        return 0.5 * ca.vertcat(-ca.dot(omega, v), w * omega + ca.cross(omega, v))

    def rates_to_omega_matrix(self, q) -> ca.SX:
        """Matrix ``E`` with ``omega = E q'`` (for unit ``q``): ``omega = 2 vec(q' (x) q*)``."""
        w, x, y, z = q[0], q[1], q[2], q[3]
        return 2 * ca.vertcat(
            ca.horzcat(-x, w, -z, y),
            ca.horzcat(-y, z, w, -x),
            ca.horzcat(-z, -y, x, w),
        )

    def check_singularity(self, q, where: str) -> None:
        if float(np.linalg.norm(np.asarray(q, dtype=float))) < 1e-12:
            raise SingularConfigurationError(f"{where}: quaternion has zero norm")


def quaternion_from_rotation(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(qw, qx, qy, qz)`` of a rotation matrix (Shepperd's method), ``qw >= 0``; a stack
    ``(..., 3, 3)`` of matrices gives ``(..., 4)`` at once (a robot's guess converts thousands of them)."""
    R = np.asarray(R, dtype=float)
    tr = np.trace(R, axis1=-2, axis2=-1)
    # Shepperd: divide by the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 (the candidates below, each minus one).
    k = np.argmax(np.stack([tr, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1), axis=-1)
    diag = np.where(k == 0, tr, 2 * np.take_along_axis(
        np.stack([R[..., 0, 0], R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1), k[..., None], axis=-1)[..., 0] - tr)
    big = 0.5 * np.sqrt(1 + diag)
    skew = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    sym = np.stack([R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]], axis=-1)
    # Row k of the table: the quaternion's components (w, x, y, z) times 4 big, from the off-diagonal terms;
    # component k itself is big.
    zero = np.zeros_like(big)
    table = np.stack([
        np.stack([zero, skew[..., 0], skew[..., 1], skew[..., 2]], axis=-1),
        np.stack([skew[..., 0], zero, sym[..., 0], sym[..., 1]], axis=-1),
        np.stack([skew[..., 1], sym[..., 0], zero, sym[..., 2]], axis=-1),
        np.stack([skew[..., 2], sym[..., 1], sym[..., 2], zero], axis=-1)], axis=-2)
    q = np.take_along_axis(table, k[..., None, None], axis=-2)[..., 0, :] / (4 * big)[..., None]
    np.put_along_axis(q, k[..., None], big[..., None], axis=-1)
    return np.where(q[..., :1] >= 0, q, -q)


Rotation = EulerSequence | UnitQuaternion


def rotation_from_name(name: str | Rotation) -> Rotation:
    """``"313"``, ``"321"`` (any Euler sequence) or ``"quaternion"``."""
    if isinstance(name, (EulerSequence, UnitQuaternion)):
        return name
    if name == "quaternion":
        return UnitQuaternion()
    return EulerSequence(str(name))
