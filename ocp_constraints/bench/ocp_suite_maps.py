"""Our solutions mapped into the suite's minimal coordinates, to start the reference there.

The reference (:func:`.ocp_suite_peers.collocate` on :mod:`.ocp_suite_minimal`) is a separate
nonlinear program with local optima of its own (the swing-ups have several: from the linear
guess the minimal acrobot lands at J = 25.9 where ours lands at 30.6 on the same mesh). Started
from our solution mapped into its coordinates, it converges to the optimum nearest ours, so the
comparison is between the same local optimum; it is still solved to IPOPT's tolerance on its
own equations. Each map takes ``(sol, inputs, t)``: our :class:`~ocp_constraints.OCPSolution`,
our input names in the minimal problem's control order, and times (s); it returns the minimal
states ``X`` (one row per state) and controls ``U`` at ``t``.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from . import ocp_suite_params as P


def angles(names: list[str], signs: list[float] | None = None) -> Callable:
    """Minimal states ``(coordinates, their rates)``: our named coordinates times ``signs``."""
    signs = signs or [1.0] * len(names)

    def states(sol, inputs: list[str], t: np.ndarray):
        X = np.array([s * sol.interpolate(n, t) for n, s in zip(names, signs)]
                     + [s * sol.interpolate(_rate(n), t) for n, s in zip(names, signs)])
        return X, _controls(sol, inputs, t)

    return states


def disk_states(sol, inputs: list[str], t: np.ndarray):
    """The rolling disk's minimal state: (x, y, psi, theta, phi) and the angle rates (its speeds)."""
    q = [f"disk.{c}" for c in ("x", "y", "psi", "theta", "phi")]
    X = np.array([sol.interpolate(n, t) for n in q] + [sol.interpolate(f"{n}_dot", t) for n in q[2:]])
    return X, _controls(sol, inputs, t)


def quadrotor_states(sol, inputs: list[str], t: np.ndarray):
    """The quadrotor's minimal state: position, 3-2-1 angles (yaw, pitch, roll) of its quaternion,
    the load's angles ``a = asin(r_y)``, ``b = atan2(-r_x, -r_z)`` of the unit rod ``r`` from the
    hook (:func:`.ocp_suite_minimal_3d.quadrotor_load`: ``r = R2(b) R1(a) (0, 0, -1)``), and their
    rates by second-order differences on ``t`` (a starting point only: the reference is solved to
    IPOPT's tolerance from there)."""
    v = {n: sol.interpolate(n, t) for n in ("quad.x", "quad.y", "quad.z", "quad.qw", "quad.qx", "quad.qy", "quad.qz",
                                            "ball.x", "ball.y", "ball.z")}
    norm = np.sqrt(v["quad.qw"] ** 2 + v["quad.qx"] ** 2 + v["quad.qy"] ** 2 + v["quad.qz"] ** 2)
    w, x, y, z = (v[f"quad.q{c}"] / norm for c in "wxyz")
    R20, R21, R22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    R00, R10 = 1 - 2 * (y * y + z * z), 2 * (x * y + w * z)
    R02, R12 = 2 * (x * z + w * y), 2 * (y * z - w * x)
    centre = np.array([v["quad.x"], v["quad.y"], v["quad.z"]])
    hook = centre - P.QUAD["hook"] * np.array([R02, R12, R22])        # R (0, 0, -hook)
    r = np.array([v["ball.x"], v["ball.y"], v["ball.z"]]) - hook
    r /= np.linalg.norm(r, axis=0)
    q = np.vstack([centre, np.arctan2(R10, R00), -np.arcsin(np.clip(R20, -1, 1)), np.arctan2(R21, R22),
                   np.arcsin(np.clip(r[1], -1, 1)), np.arctan2(-r[0], -r[2])])
    return np.vstack([q, np.gradient(q, t, axis=1)]), _controls(sol, inputs, t)


def _controls(sol, inputs: list[str], t: np.ndarray) -> np.ndarray:
    return np.array([sol.interpolate(n, t) for n in inputs])


def _rate(name: str) -> str:
    return name.replace(".x", ".vbar_x") if name.endswith(".x") else f"{name}_dot"
