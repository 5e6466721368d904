"""Fit the JW implant's condyle spheres and plateau planes and store them with the package.

    python scripts/knee_implant_geometry.py

Reads ``femPoints_188.csv``, ``tibPoints_100.csv``, ``facesTib{1,2}_100.csv`` from
``../shared/data/grand-challenge-knee-jw/workshop_bcn2024/ExperimentalData`` (see
:func:`ocp_constraints.biomech.knee_contact.implant_geometry`) and writes
``ocp_constraints/biomech/data/jw_knee_implant_geometry.json``.
"""
import json
from pathlib import Path

from ocp_constraints.biomech.knee_contact import GEOMETRY_FILE, implant_geometry

IMPLANT_DIR = (Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw" / "workshop_bcn2024"
               / "ExperimentalData")

if __name__ == "__main__":
    g = implant_geometry(IMPLANT_DIR)
    data = {"source": "workshop_bcn2024/ExperimentalData (femPoints_188, tibPoints_100, facesTib1_100, facesTib2_100)",
            "frames": "femoral component (centres) and tibial tray (heights), JW model frames, m",
            "method": "least-squares circle per condyle (sagittal x-y plane, z = mean z of the distal points); "
                      "plateau plane Y = lowest vertex of each compartment",
            "parameters": g.as_params()}
    GEOMETRY_FILE.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {GEOMETRY_FILE} from {IMPLANT_DIR}")
