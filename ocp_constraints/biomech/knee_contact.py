"""Condyle contact of the JW knee implant (issue 7, step 1; paper sec. 6, Figs. 7-8).

Frames. The JW model's knee (``CustomJoint knee``) places the femoral component (frame
M) relative to the tibial tray (frame F) by ``R_FM = Rz(flexion) Rx(adduction)
R_{-y}(rotation)`` and ``p_FM = tx X + ty Y + tz Z``. With the constant basis change
``S = [-Y, X, Z]`` (columns, tray frame; right-handed: ``-Y x X = Z``) this is the
paper's 3-2-1 sequence, ``S^T R_FM S = R3(psi) R2(theta) R1(phi)`` with
``psi = knee_flexion`` (about ``e3 = Z``, the flexion axis), ``theta = knee_adduction``
(varus-valgus, about the floating axis ``g_2``) and ``phi = knee_rotation``
(internal-external, about ``e1 = -Y``, the tibial long axis). The knee scene's fixed
basis is the tray's basis rotated by ``S``; positions there read ``S^T p =
(-ty, tx, tz)``.

Both component frames are the bones' frames turned by pi about y (weld offsets of the
JW model), so in them +X is posterior and +Z is *medial* for this right knee.

Geometry (``implant_geometry``), from the workshop contact meshes in the femoral and
tibial component frames (the same frames as the JW model: ``KneeProsthesis.osim`` uses
the same knee definition and ``knee_ty = 0.042``): each femoral condyle (mesh points
with z > 0: medial, z < 0: lateral) is a circle in the sagittal plane fitted by least
squares (centre ``(x_c, y_c)``, radius ``rho``) at the mean z of its distal points;
each tibial compartment (``facesTib1``: z > 0, medial; ``facesTib2``: lateral) is the
plane ``Y = h`` through its lowest vertex, normal ``n = Y`` (the tray axis, the axis
along which the instrumented tray measures its loads). The contact point of condyle k
is ``c_k - rho_k n``. In the knee model (:mod:`.knee_model`) each condyle is the sphere
of that radius about ``c_k``. The fit is stored in ``data/jw_knee_implant_geometry.json``
(``scripts/knee_implant_geometry.py``; a test checks it against the meshes) so the
package works without the data folder.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ImplantGeometryError

S = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])   # columns -Y, X, Z in tray coordinates
GEOMETRY_FILE = Path(__file__).resolve().parent / "data" / "jw_knee_implant_geometry.json"
KNEE_COORDINATES = ["knee_flexion", "knee_adduction", "knee_rotation", "knee_tx", "knee_ty", "knee_tz"]


@dataclass
class ImplantGeometry:
    """Condyle circles (femoral frame) and plateau heights (tray frame), m."""

    medial_centre: np.ndarray
    medial_radius: float
    lateral_centre: np.ndarray
    lateral_radius: float
    medial_height: float
    lateral_height: float

    def as_params(self) -> dict[str, float]:
        out = {}
        for side in ("medial", "lateral"):
            c = getattr(self, f"{side}_centre")
            out.update({f"{side}_cx": float(c[0]), f"{side}_cy": float(c[1]), f"{side}_cz": float(c[2]),
                        f"{side}_radius": float(getattr(self, f"{side}_radius")),
                        f"{side}_height": float(getattr(self, f"{side}_height"))})
        return out


def _read(path: Path) -> np.ndarray:
    try:
        return np.loadtxt(path, delimiter=",", ndmin=2)
    except (OSError, ValueError) as exc:
        raise ImplantGeometryError(f"{path}: cannot read the implant mesh: {exc}") from exc


def implant_geometry(folder) -> ImplantGeometry:
    """Fit the condyle circles and plateau planes from ``femPoints_188.csv`` and ``tibPoints_100.csv``."""
    folder = Path(folder)
    P = _read(folder / "femPoints_188.csv")
    T = _read(folder / "tibPoints_100.csv")
    out = {}
    for side, sign, faces in (("medial", 1.0, "facesTib1_100.csv"), ("lateral", -1.0, "facesTib2_100.csv")):
        V = P[P[:, 2] * sign > 0]
        A = np.column_stack([2 * V[:, :2], np.ones(len(V))])
        x, *_ = np.linalg.lstsq(A, (V[:, :2] ** 2).sum(1), rcond=None)
        radius = float(np.sqrt(x[2] + x[:2] @ x[:2]))
        distal = V[V[:, 1] < V[:, 1].min() + 0.003]
        out[f"{side}_centre"] = np.array([x[0], x[1], distal[:, 2].mean()])
        out[f"{side}_radius"] = radius
        F = _read(folder / faces).astype(int) - 1
        out[f"{side}_height"] = float(T[np.unique(F), 1].min())
    return ImplantGeometry(**out)


def stored_geometry(path=GEOMETRY_FILE) -> dict[str, float]:
    """The fit of :func:`implant_geometry` stored with the package (``scripts/knee_implant_geometry.py``)."""
    try:
        data = json.loads(Path(path).read_text())
        return {k: float(v) for k, v in data["parameters"].items()}
    except (OSError, ValueError, KeyError) as exc:
        raise ImplantGeometryError(f"{path}: cannot read the stored implant geometry: {exc}") from exc
