"""Bounds of the decision variables of a transcription (see :class:`~.layout.Layout`)."""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..mechanics.rotations import EulerSequence
from .free_mesh_points import scale_bounds


def variable_bounds(tr, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``lbx, ubx``: the user's bounds on coordinates, speeds and inputs at every point, the free
    final time's bounds, and bands that keep Euler angles off their singularities."""
    lay, pr = tr.layout, tr.problem
    lo = [np.full(n, -np.inf) for n in lay.sizes()]
    hi = [np.full(n, np.inf) for n in lay.sizes()]
    names_x = pr.model.coordinate_names + pr.model.speed_names
    names_w = list(pr.model.inputs)
    for name, (a, b) in pr.bounds.items():
        if name in names_x:
            r = names_x.index(name)
            lo[0][r :: lay.nx], hi[0][r :: lay.nx] = a, b
        elif name in names_w:
            r = names_w.index(name)
            lo[3][r :: lay.n_in], hi[3][r :: lay.n_in] = a, b
        else:
            raise ModelError(f"bound on '{name}': only coordinates, speeds and inputs take bounds; use subject_to for rates")
    if lay.free_time:
        lo[5][:], hi[5][:] = pr.t_final_bounds
    if lay.n_phases:
        lo[6][:], hi[6][:] = scale_bounds(tr)
    _keep_away_from_euler_singularities(tr, lo[0], hi[0], names_x, x0[: lay.nx])
    return np.concatenate(lo), np.concatenate(hi)


def _keep_away_from_euler_singularities(tr, lo, hi, names_x, x_start) -> None:
    """Bound each Euler body's second angle inside the regular band of its start value.

    Where the user set no bound: the dual Euler basis (and so the dynamics) is
    singular at theta = k pi (proper sequences) or pi/2 + k pi (Tait-Bryan), and an
    iterate that crosses there makes IPOPT wander.
    """
    lay = tr.layout
    for b in tr.eqs.bodies:
        rot = b.rotation
        name = f"{b.name}.theta"
        if not isinstance(rot, EulerSequence) or name in tr.problem.bounds:
            continue
        r = names_x.index(name)
        offset = 0.0 if rot.is_proper else np.pi / 2
        k = np.floor((x_start[r] + offset) / np.pi)
        margin = max(rot.singularity_tolerance, 1e-3)
        lo[r :: lay.nx] = k * np.pi - offset + margin
        hi[r :: lay.nx] = (k + 1) * np.pi - offset - margin
