"""The knee data that belong to one model file: muscle-path fits and implant contact geometry.

The fitted muscle-tendon lengths (:mod:`.knee_muscles`) are OpenSim's paths *of one model*,
and the condyle spheres and plateau planes (:mod:`.knee_contact`) are the geometry of *its*
implant. They are stored keyed by the SHA-256 of the model file's bytes, never by its name,
so one model's fits are never applied to another (a scaled copy, another subject, an edited
file all have other keys):

1. the package's own data (``data/knee_models.json``: the JW model of the Grand Challenge
   data, whose fits and geometry ship with the package);
2. the user's cache, ``$OCP_CONSTRAINTS_CACHE/knee_models/<sha256>/`` (default
   ``~/.cache/ocp_constraints``), where data built for other models are kept.

For a model in neither, the data are built with the documented preprocessing:

* muscle paths: OpenSim's own path lengths sampled over the range of motion, in its own
  process (``python -m ocp_constraints.biomech.knee_paths_opensim``; needs the optional
  ``opensim`` extra, ``pip install -e ".[opensim]"``), with the moment arms of a unit tension
  along OpenSim's current path (:mod:`.knee_paths_opensim`), then the joint fits of :func:`~.knee_path_fits.fit_paths` (the same
  route as ``scripts/knee_muscle_fits.py``);
* contact geometry: the circle and plane fits of :func:`~.knee_contact.implant_geometry`
  from the implant's contact meshes (``femPoints_188.csv``, ``tibPoints_100.csv``,
  ``facesTib{1,2}_100.csv``), which only the user can give (``knee --implant-meshes DIR``).

Without them the run is refused with a :class:`KneeError` that says what is missing and how
to provide it.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import KneeError, OcpConstraintsError

DATA_DIR = Path(__file__).resolve().parent / "data"
INDEX_FILE = DATA_DIR / "knee_models.json"
PATHS_NAME, GEOMETRY_NAME = "muscle_paths.json", "implant_geometry.json"
HOLDOUT_STORED = 60     # held-out poses whose OpenSim moment arms are stored with the fits (tests)
# the preprocessing that made a fits file: a cached file of another (older) one is not used (issue 15: before the
# fifth round the moment arms were computeMomentArm's, before the fourth the lengths' alone)
PREPROCESSING = "lengths and the string's moment arms along OpenSim's current path (issue 15, fifth round)"


@dataclass
class KneeModelData:
    """Where the knee data of one model file are: ``sha256`` of the file, the muscle-path file,
    the implant geometry (parameters of :func:`~.knee_contact.stored_geometry`) and their origin."""

    sha256: str
    muscle_paths: Path
    geometry: dict[str, float]
    geometry_file: Path
    source: str

    def summary(self) -> dict:
        return {"model_sha256": self.sha256, "muscle_paths": str(self.muscle_paths),
                "implant_geometry": str(self.geometry_file), "source": self.source}


def model_sha256(model) -> str:
    """SHA-256 of the model file's bytes (the key of its knee data)."""
    try:
        return hashlib.sha256(Path(model).read_bytes()).hexdigest()
    except OSError as exc:
        raise KneeError(f"{model}: cannot read the model file: {exc}") from exc


def cache_dir() -> Path:
    """``$OCP_CONSTRAINTS_CACHE/knee_models`` (default ``~/.cache/ocp_constraints/knee_models``)."""
    root = os.environ.get("OCP_CONSTRAINTS_CACHE") or Path(os.environ.get("XDG_CACHE_HOME") or
                                                             Path.home() / ".cache") / "ocp_constraints"
    return Path(root) / "knee_models"


def opensim_available() -> bool:
    """Whether the optional ``opensim`` package is installed (looked up, not imported: it clashes with CasADi)."""
    return importlib.util.find_spec("opensim") is not None


def _package_entry(sha: str) -> dict | None:
    try:
        index = json.loads(INDEX_FILE.read_text())
    except (OSError, ValueError) as exc:
        raise KneeError(f"{INDEX_FILE}: cannot read the index of the package's knee models: {exc}") from exc
    return index["models"].get(sha)


def knee_model_data(model, implant_meshes=None, build: bool = True) -> KneeModelData:
    """The muscle-path fits and implant geometry of ``model`` (module docstring): found by the
    file's content, or built (``build=True``) with the documented preprocessing, or refused."""
    from .knee_contact import stored_geometry

    sha = model_sha256(model)
    entry = _package_entry(sha)
    if entry is not None:
        geo = DATA_DIR / entry["implant_geometry"]
        return KneeModelData(sha, DATA_DIR / entry["muscle_paths"], stored_geometry(geo), geo,
                             f"package data for {entry['name']}")
    folder = cache_dir() / sha
    paths_file, geo_file = folder / PATHS_NAME, folder / GEOMETRY_NAME
    built = []
    if not geo_file.exists():
        if implant_meshes is None:
            raise KneeError(f"{model}: no implant contact geometry for this model file (SHA-256 {sha[:12]}...; the "
                            "package has the JW model's only, and one model's geometry is never used for another): "
                            "give the implant's contact meshes with --implant-meshes DIR (femPoints_188.csv, "
                            "tibPoints_100.csv, facesTib1_100.csv, facesTib2_100.csv, as in the JW workshop data)")
        _write_geometry(implant_meshes, geo_file)
        built.append("implant geometry")
    stale = paths_file.exists() and _preprocessing(paths_file) != PREPROCESSING
    if not paths_file.exists() or stale:
        if not build or not opensim_available():
            why = "building them was not asked for" if not build else "the optional 'opensim' package is not installed"
            have = (f"only muscle-path fits of an older preprocessing ({paths_file}; made with "
                    f"'{_preprocessing(paths_file)}', not '{PREPROCESSING}')" if stale else
                    "no muscle-path fits for this model file")
            raise KneeError(f"{model}: {have} (SHA-256 {sha[:12]}...; the package "
                            f"has the JW model's only, and one model's fits are never used for another), and "
                            f"{why}: install it (pip install -e \".[opensim]\") so that OpenSim's paths of this "
                            "model are sampled and fitted (lengths and moment arms, about 3 minutes of CPU), "
                            "or use the JW model")
        build_muscle_paths(model, paths_file)
        built.append("muscle-path fits" + (" (the cached ones were of an older preprocessing)" if stale else ""))
    source = f"built for this model ({', '.join(built)}) in {folder}" if built else f"cache {folder}"
    return KneeModelData(sha, paths_file, stored_geometry(geo_file), geo_file, source)


def _preprocessing(paths_file: Path) -> str:
    """The ``preprocessing`` stamp of a fits file (``"unknown"`` for files made before stamps existed)."""
    try:
        return str(json.loads(Path(paths_file).read_text()).get("preprocessing", "unknown"))
    except (OSError, ValueError):
        return "unreadable"


def _write_geometry(meshes, out: Path) -> None:
    from .knee_contact import implant_geometry

    g = implant_geometry(meshes)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"source": str(meshes), "method": "knee_contact.implant_geometry",
                               "parameters": g.as_params()}, indent=1) + "\n")


def holdout_arms(raw: dict, count: int = HOLDOUT_STORED) -> dict:
    """The first ``count`` held-out poses where OpenSim's moment arms were sampled, and those arms (7 digits)."""
    n_fit = int(0.8 * len(raw["samples"]))
    rows = [r for r, k in enumerate(raw["arm_indices"]) if k >= n_fit][:count]
    return {"coordinates": raw["coordinates"],
            "poses": [[float(f"{v:.7g}") for v in raw["samples"][raw["arm_indices"][r]]] for r in rows],
            "moment_arms": {m: {"coordinates": a["coordinates"],
                                "values": [[float(f"{v:.7g}") for v in a["values"][r]] for r in rows]}
                            for m, a in raw["moment_arms"].items()}}


def build_muscle_paths(model, out: Path, samples: int = 4000, seed: int = 7, raw: dict | None = None) -> Path:
    """OpenSim's path lengths and moment arms of ``model`` (own process; or ``raw``, a sampling already
    made by :mod:`.knee_paths_opensim` for this model), fitted and written to ``out``."""
    from .knee_path_fits import fit_paths, fit_units

    if raw is None:
        raw = sample_muscle_paths(model, samples, seed)
    try:
        fits = fit_paths(raw)
        units = fit_units(raw, fits)
    except (KeyError, ValueError, OcpConstraintsError) as exc:
        raise KneeError(f"{model}: cannot fit the sampled muscle paths: {exc}") from exc
    data = {"source": "OpenSim path lengths and moment arms (ocp_constraints.biomech.knee_paths_opensim), "
                      "polynomial fits (ocp_constraints/biomech/knee_path_fits.py)",
            "preprocessing": PREPROCESSING,
            "opensim_version": raw["opensim_version"], "model": Path(str(model)).name,
            "model_sha256": model_sha256(model), "samples": len(raw["samples"]), "seed": raw.get("seed", seed),
            "knee_ty": raw["knee_ty"], "patella_coupling": raw["patella_coupling"], "fits": fits,
            "unit_suffix": raw["unit_suffix"], "unit_fits": units, "sweep_knee_flexion": raw["sweep_knee_flexion"],
            "sweep_muscles": raw["muscles"], "sweep_moment_arms_opensim": raw["sweep_moment_arms"],
            "sweep_moment_arm_knee_fd_coupled_opensim": raw["sweep_moment_arm_knee_fd_coupled"],
            "sweep_moment_arms_string": raw.get("sweep_moment_arms_string", {}),
            "unspanned_moment_arms_max_opensim": raw.get("unspanned_moment_arms_max", {})}
    if "moment_arms" in raw:       # OpenSim's moment arms at held-out poses (not fitted on), for the tests
        data["holdout_moment_arms_opensim"] = holdout_arms(raw)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp_out = out.with_suffix(".tmp")
    tmp_out.write_text(json.dumps(data))
    tmp_out.replace(out)
    return out


def sample_muscle_paths(model, samples: int = 4000, seed: int = 7) -> dict:
    """Run :mod:`.knee_paths_opensim` on ``model`` in its own process and return its output."""
    with tempfile.TemporaryDirectory() as tmp:
        raw_path = Path(tmp) / "raw.json"
        proc = subprocess.run([sys.executable, "-m", "ocp_constraints.biomech.knee_paths_opensim", str(model),
                               str(raw_path), str(samples), str(seed)], capture_output=True, text=True)
        if proc.returncode != 0:
            tail = (proc.stderr.strip().splitlines() or ["(no message)"])[-1]
            raise KneeError(f"{model}: OpenSim's muscle-path sampling failed: {tail}")
        return json.loads(raw_path.read_text())
