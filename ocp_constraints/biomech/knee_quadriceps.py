"""The quadriceps' pull on the tibia through one patellar ligament (issue 15, candidate C13).

The JW model file gives every quadriceps head its own last path segment from the patella to the tibia:
rectus femoris and vastus intermedius run from the patellar apex to one tibial point (tibia frame
z = 3.97 and 4.0 mm), the vastus lateralis to z = +14 mm and the vastus medialis to z = -6 mm. The
patella is coupled to the femur in this model, so on the knee's five locked directions
(:data:`.knee_muscles.SECONDARY`) only that segment changes length and a head's moment arms there
(``-dL/dq``, paper eqs. 35-41) are its segment's: -16 mm (vastus lateralis) and +12 mm (vastus
medialis) about knee adduction, against 0 and -3 mm for the central heads. Anatomically the
quadriceps tendon inserts on the patella, and the patella is tied to the tibial tuberosity by one
patellar ligament, so every head pulls the tibia along that ligament. :func:`patellar_ligament_arms`
gives the vastus lateralis and medialis the locked-row moment arms of the model's own central line
(the mean of the rectus femoris's and vastus intermedius's rows); knee flexion and all other rows,
which depend on the whole path through the coupled patella, are the model's.

Left out: the medial and lateral patellar retinacula, expansions of the vasti to the tibial condyles,
carry part of the vasti's tension past the patella; there are no data for that part here.
"""
from __future__ import annotations

import numpy as np

from ..errors import KneeError
from .knee_muscles import SECONDARY

CENTRAL = ("recfem", "vasint")       # the heads whose last segments are the patellar ligament's line
SIDE_VASTI = ("vaslat", "vasmed")    # the heads whose last segments reach the tibia 10 mm either side of it


def patellar_ligament_arms(R: np.ndarray, muscles: list[str], rows: list[str] | None = None) -> np.ndarray:
    """Moment arms ``R`` (frames x rows x muscles; m, or dimensionless on the translations; rows by default
    those of :func:`.knee_static.frame_data`) with the vastus lateralis's and medialis's rows of the locked
    knee directions replaced by the central ligament line's."""
    from .knee_static import RESERVED

    rows = RESERVED + SECONDARY if rows is None else rows
    missing = [m for m in CENTRAL + SIDE_VASTI if m not in muscles]
    if missing:
        raise KneeError(f"quadriceps 'patellar-ligament' needs the JW quadriceps heads; the model's muscle paths "
                        f"have no {missing} (use --quadriceps model-paths)")
    R = np.array(R, float, copy=True)
    locked = [rows.index(c) for c in SECONDARY]
    central = np.mean([R[:, locked, muscles.index(m)] for m in CENTRAL], axis=0)
    for m in SIDE_VASTI:
        R[:, locked, muscles.index(m)] = central
    return R


__all__ = ["CENTRAL", "SIDE_VASTI", "patellar_ligament_arms"]
