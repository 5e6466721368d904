"""Legs, feet and force plates (step 3 of :mod:`ocp_constraints.biomech.gait`): each loaded plate
goes to the foot whose heel-toe segment is nearest its centre of pressure.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GaitError
from .opensim_files import Plate
from .osim_model import OsimModel

CONTACT_THRESHOLD = 20.0   # N, vertical force above which a plate is loaded
FOOT_TOLERANCE = 0.25      # m, largest horizontal distance from a centre of pressure to its foot


# -- 3. legs, feet and force plates ----------------------------------------------------------------

@dataclass
class Leg:
    side: str
    hip: str
    chain: list[str]

    @property
    def foot(self) -> str:
        return self.chain[-2]


def find_legs(osim: OsimModel) -> dict[str, Leg]:
    """The two legs: subtrees hanging from the pelvis, side from the hip's z (+z is right)."""
    root = osim.outboard(osim.joints[osim.order[0]])
    legs = {}
    for name in osim.order:
        j = osim.joints[name]
        if osim.inboard(j) != root:
            continue
        chain = [osim.outboard(j)]
        while True:
            kids = [osim.outboard(k) for k in (osim.joints[n] for n in osim.order) if osim.inboard(k) == chain[-1]]
            if not kids:
                break
            chain.append(max(kids, key=lambda b: (_depth(osim, b), osim.bodies[b].mass)))
        fr = j.parent if not j.reversed else j.child
        if len(chain) < 4 or abs(fr.p[2]) < 1e-3:
            continue
        side = "right" if fr.p[2] > 0 else "left"
        if side not in legs or len(chain) > len(legs[side].chain):
            legs[side] = Leg(side, name, chain)
    if set(legs) != {"left", "right"}:
        raise GaitError(f"{osim.path}: could not find a left and a right leg below '{root}'")
    return legs


def _depth(osim: OsimModel, body: str) -> int:
    kids = [osim.outboard(osim.joints[n]) for n in osim.order if osim.inboard(osim.joints[n]) == body]
    return 1 + max((_depth(osim, k) for k in kids), default=0)


def assign_plates(plates: list[Plate], feet: dict[str, tuple[np.ndarray, np.ndarray]],
                  up: np.ndarray, where: str) -> dict[str, str]:
    """Which foot stands on each loaded plate: ``plate -> side``.

    ``feet[side]`` holds the heel (hindfoot origin) and toe positions (samples x 3, at
    the plates' samples); the plate goes to the foot whose heel-toe segment is nearest (horizontal
    distance, median over the loaded samples) to the centre of pressure.
    """
    out = {}
    for pl in plates:
        loaded = pl.force @ up > CONTACT_THRESHOLD
        if not loaded.any():
            continue
        cop = pl.point[loaded]
        dist = {}
        for side, (heel, toe) in feet.items():
            h, tt = heel[loaded], toe[loaded]
            d = tt - h
            d -= np.outer(d @ up, up)
            w = cop - h
            w -= np.outer(w @ up, up)
            s = np.clip(np.einsum("ij,ij->i", w, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-12), 0, 1)
            dist[side] = float(np.median(np.linalg.norm(w - s[:, None] * d, axis=1)))
        side = min(dist, key=dist.get)
        if dist[side] > FOOT_TOLERANCE:
            raise GaitError(f"{where}: {pl.name} is loaded ({int(loaded.sum())} samples) but no foot stands on it: "
                            f"the nearest foot ({side}) is {dist[side]:.2f} m from its centre of pressure")
        out[pl.name] = side
    return out


