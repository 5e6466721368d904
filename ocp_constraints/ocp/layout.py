"""The decision vector of a transcription: which block holds which variables.

Blocks, in order (see :mod:`ocp_constraints.ocp.transcription`): states ``x_i`` at every
collocation point, accelerations (at every point, or at ``t_0`` only where the scheme gives
them), multipliers ``lambda_i``, inputs ``w_i``, Posa slacks ``gamma_i`` (not at ``t_0``) and
the free final time; then, where the scheme has free mesh points, each phase's time scale
(:mod:`~ocp_constraints.ocp.free_mesh_points`), which :meth:`Layout.split` leaves out.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


@dataclass
class Layout:
    """Where each block of the decision vector lives (all column-major blocks)."""

    n_points: int
    nx: int
    nu: int
    nc: int
    nh: int
    n_in: int
    free_time: bool
    n_acc: int  # points with acceleration variables: all, or t0 only where the scheme gives them
    n_phases: int = 0   # phases of unknown length (free mesh points + 1), or 0

    def sizes(self) -> list[int]:
        P = self.n_points
        return [self.nx * P, self.nu * self.n_acc, self.nc * P, self.n_in * P, self.nh * (P - 1), int(self.free_time),
                self.n_phases]

    def split(self, w):
        out, start = [], 0
        for n in self.sizes():
            out.append(w[start : start + n])
            start += n
        P = self.n_points
        X = ca.reshape(out[0], self.nx, P)
        A = ca.reshape(out[1], self.nu, self.n_acc)
        L = ca.reshape(out[2], self.nc, P)
        W = ca.reshape(out[3], self.n_in, P)
        Gm = ca.reshape(out[4], self.nh, P - 1)
        return X, A, L, W, Gm, out[5]
