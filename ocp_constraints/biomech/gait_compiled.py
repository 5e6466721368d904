"""A gait model's inverse dynamics as one CasADi function of the frame, built once and kept on disk.

Per frame, from the coordinates ``p``, their rates ``p'``, ``p''``, the bodies' unit
quaternions and the measured ground loads per body (force ``F`` and its moment ``M_O``
about the ground origin), :func:`gait_functions` gives one SX function that returns

- the bodies' ``q, u, u'`` (forward kinematics by AD, :meth:`OsimModel.kinematic_expressions`),
- ``f_ext`` (``F`` and ``M_O - xbar x F``, the moment about the centre of mass),
- ``lambda, tau`` and the balance residual: ``G^T lambda + B tau = M u' - f - f_ext``
  (paper eq. 13) solved block by block (:func:`ocp_constraints.dynamics.inverse.block_triangular_solve`),
- the generalized force of every OpenSim coordinate, ``Phi = lambda A + tau`` with
  ``A = G dU/dp'`` (eqs. 38-41), as ``J^T (G^T lambda)`` by reverse-mode AD,
- DESIGN.md's joint-load columns (eqs. 26-27).

It is ``Function.map``-ped over all frames and evaluated once (no Python loop per frame).
Building it from the ``.osim`` (our constraint model, :func:`.gait_model.constraint_model`,
and the symbolic graphs) costs 1-3 s of CPU; the result is therefore kept on disk: the
serialized CasADi functions and the names a result needs, under
``$XDG_CACHE_HOME/ocp_constraints/gait`` (see :func:`ocp_constraints.dynamics.compiled.cache_dir`),
keyed by the SHA-256 of the ``.osim`` file's bytes, the CasADi version and the source text of
the modules that build it (so an edit of the code or of the model is another key). The
frame function is compiled to C (:mod:`ocp_constraints.dynamics.compiled`) when asked for
(``compiled="always"``); with ``"auto"`` a compiled copy in the cache is loaded, a call with
:data:`COMPILE_ABOVE_FRAMES` frames or more compiles now (it pays within the call), and any other
cache miss runs on CasADi's virtual machine while a detached process compiles the library for the
next runs (one note: "compiling the frame function in the background for later runs").
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from ..errors import GaitError
from .osim_model import OsimModel

FORMAT = 1
_PATH = "{osim_path}"        # the model file's path in stored warnings (the same model may sit anywhere)
#: modules whose source decides the functions: an edit of any of them is a new cache key
_SOURCES = ("biomech/gait_compiled.py", "biomech/gait_model.py", "biomech/osim_model.py", "biomech/osim_functions.py",
            "biomech/osim_kinematics.py",
            "dynamics/inverse.py", "mechanics")
_MEMO: dict[str, "GaitFunctions"] = {}      # per process: a model's functions are loaded once
#: "auto" compiles from this many frames in one call on (JW, 37,500 operations a frame, loaded 2-core
#: machine, CPU time: compiling costs 6.3 s once, the virtual machine 0.33 ms a frame, the compiled code
#: 0.06 ms; both scale with the size of the function, so the break-even, ~23,000 frames, does not)
COMPILE_ABOVE_FRAMES = 25_000
CHUNK = 512          # frames a mapped evaluation takes at once (see GaitFunctions.evaluate)
KEEP = 16            # model files kept in the disk cache (the newest)


def _source_digest() -> str:
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for rel in _SOURCES:
        p = root / rel
        for f in sorted(p.glob("*.py")) if p.is_dir() else [p]:
            h.update(f.name.encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def model_key(osim_path) -> str:
    """The cache key of a model file: SHA-256 of its bytes, CasADi's version, the builder's source."""
    h = hashlib.sha256()
    for part in (str(FORMAT), ca.__version__, _source_digest()):
        h.update(part.encode() + b"\0")
    h.update(Path(osim_path).read_bytes())
    return h.hexdigest()[:32]


@dataclass
class GaitFunctions:
    """The frame functions of one model and the names that go with them.

    ``poses``: ``p -> (R, x)``, every body's rotation (9 entries, column major) and origin.
    ``frame``: ``(p, pdot, pddot, quat, F, M_O, t) -> (q, u, udot, f_ext, lam, tau,
    generalized_forces, residual, loads)`` (see the module docstring). ``system``: ``(q, u,
    udot, t) -> (A, b)`` of one sample, for the rank check. ``meta``: bodies, constraint and
    input names, joints, load column names, warnings. ``source``: ``"built"``, ``"disk cache"``
    or ``"memory"``; ``compiled``: whether ``frame`` is machine code.
    """

    key: str
    poses: ca.Function
    frame: ca.Function
    system: ca.Function
    meta: dict
    source: str = "built"
    compiled: bool = False
    build_s: float = 0.0
    _model: tuple | None = field(default=None, repr=False)
    _maps: dict = field(default_factory=dict, repr=False)

    def model_and_equations(self, osim: OsimModel):
        """Our :class:`Model` and its :class:`SystemEquations` (built on first use: 1-3 s)."""
        if self._model is None:
            from ..mechanics.equations import SystemEquations
            from .gait_model import constraint_model

            model, joints = constraint_model(osim)
            eqs = SystemEquations(model)
            if eqs.constraint_names != self.meta["constraints"]:
                raise GaitError(f"{osim.path}: the model built now differs from the cached functions "
                                f"(key {self.key}); delete {cache_file(self.key)} and run again")
            self._model = (model, eqs, joints)
        return self._model

    def evaluate(self, F: ca.Function, *args) -> list[np.ndarray]:
        """``F`` (``poses`` or ``frame``) at every frame: ``args`` are arrays with one column a frame.

        Evaluated in chunks of :data:`CHUNK` frames through one ``F.map(CHUNK)``, made once per
        function and size: making a map costs in proportion to its width (0.16 s for 2,000
        frames of the JW frame function, more than evaluating them), a chunked loop does not.
        """
        from ..mechanics.fast_eval import evaluate

        N = args[0].shape[1]
        C = max(1, min(N, CHUNK))
        mapped = self._maps.get((F.name(), C))
        if mapped is None:
            mapped = self._maps[(F.name(), C)] = F.map(C)
        if N == C:
            return evaluate(mapped, *args)
        parts = []
        for s in range(0, N, C):
            chunk = [a[:, s:s + C] for a in args]
            k = chunk[0].shape[1]
            if k < C:        # the last chunk, padded with its last frame
                chunk = [np.hstack([a, np.repeat(a[:, -1:], C - k, axis=1)]) for a in chunk]
            parts.append([r[:, :k] for r in evaluate(mapped, *chunk)])
        return [np.hstack(rs) for rs in zip(*parts)]

    def check_determined(self, q0, u0, t0: float, where) -> None:
        """Raise if the multipliers and inputs are not determined at the first sample (rank of ``A``)."""
        from ..mechanics.fast_eval import evaluate

        A = evaluate(self.system, np.reshape(q0, (-1, 1)), np.reshape(u0, (-1, 1)), np.zeros((len(u0), 1)),
                     np.full((1, 1), float(t0)))[0]
        rank, n = np.linalg.matrix_rank(A), A.shape[1]
        if rank < n:
            raise GaitError(f"{where}: inverse dynamics of '{self.meta.get('name', 'model')}': multipliers and inputs "
                            f"are not determined (rank {rank} < {n} unknowns); check the model's joints for "
                            "redundant directions")

    def balance_scale(self, q, u, udot, t, fext) -> float:
        """Largest entry of ``M u' - f - f_ext`` over all samples (rows): the scale a residual is judged by."""
        from ..mechanics.fast_eval import evaluate

        b = evaluate(self.system.map(len(t)), q.T, u.T, udot.T, np.reshape(t, (1, -1)))[1].T - fext
        return float(np.abs(b).max(initial=0.0))


def cache_file(key: str) -> Path:
    from ..dynamics.compiled import cache_dir

    return cache_dir() / "gait" / f"gait_{key}.json"


def build_functions(osim: OsimModel, key: str = "") -> GaitFunctions:
    """Build the frame functions from the OpenSim model (the expensive symbolic work)."""
    import time

    from ..dynamics.inverse import InverseDynamics
    from ..mechanics.equations import SystemEquations
    from ..mechanics.load_columns import load_column_names
    from .gait_model import constraint_model

    clock = time.process_time()
    model, joints = constraint_model(osim)
    eqs = SystemEquations(model)
    bodies = list(model.bodies)
    nb, names = len(bodies), osim.coordinate_names
    inverse = InverseDynamics(eqs)
    if inverse.solution is None:
        raise GaitError(f"{osim.path}: the balances of the model are not a square, structurally nonsingular "
                        f"system ({eqs.nu} equations, {eqs.nc + eqs.inputs.numel()} unknowns): every body must "
                        "hang on exactly one joint whose six directions are constraints or coordinates")
    p, pd, pdd = (ca.SX.sym(s, len(names)) for s in ("p", "pdot", "pddot"))
    quat, F, MO, t = ca.SX.sym("quat", 4 * nb), ca.SX.sym("F", 3 * nb), ca.SX.sym("M_O", 3 * nb), ca.SX.sym("t")
    K = osim.kinematic_expressions(p, pd, pdd, bodies)
    q = ca.vertcat(*[ca.vertcat(K["xbar"][k], quat[4 * k:4 * k + 4]) for k in range(nb)])
    u = ca.vertcat(*[ca.vertcat(K["vbar"][k], K["omega"][k]) for k in range(nb)])
    udot = ca.vertcat(*[ca.vertcat(K["abar"][k], K["alpha"][k]) for k in range(nb)])
    fext = ca.vertcat(*[ca.vertcat(F[3 * k:3 * k + 3], MO[3 * k:3 * k + 3] - ca.cross(K["xbar"][k], F[3 * k:3 * k + 3]))
                        for k in range(nb)])
    lam, tau, res = inverse.solution(q, u, udot, t, fext)
    lam_sym = ca.SX.sym("lam", eqs.nc)
    GT_lam = ca.Function("GT_lam", [eqs.q, lam_sym], [eqs.G.T @ lam_sym])(q, lam)
    gen = ca.jtimes(u, pd, GT_lam, True)            # J^T G^T lambda = lambda A (eqs. 38-41)
    inputs = list(model.inputs)
    rows = [gen[c] for c in range(len(names))]
    for i, name in enumerate(inputs):
        rows[names.index(name)] += tau[i]
    loads = eqs.loads_function(q, u, t, lam)
    # common subexpressions of the inlined pieces merged (57,700 -> 37,500 operations for JW)
    frame = ca.Function("gait_frame", [p, pd, pdd, quat, F, MO, t],
                        ca.cse([q, u, udot, fext, lam, tau, ca.vertcat(*rows), res, loads]),
                        ["p", "pdot", "pddot", "quat", "F", "M_O", "t"],
                        ["q", "u", "udot", "f_ext", "lam", "tau", "generalized_forces", "residual", "loads"])
    X = osim.poses({n: p[i] for i, n in enumerate(names)})
    poses = ca.Function("gait_poses", [p], [ca.vertcat(*[ca.vec(X[b][0]) for b in bodies]),
                                            ca.vertcat(*[X[b][1] for b in bodies])], ["p"], ["R", "x"])
    meta = {"format": FORMAT, "name": model.name, "bodies": bodies, "coordinates": names, "constraints": eqs.constraint_names,
            "inputs": inputs, "load_columns": load_column_names(eqs),
            "joints": {n: {"parent": j.parent, "child": j.child, "constraints": j.constraints, "inputs": j.inputs}
                       for n, j in joints.items()},
            "warnings": [w.replace(str(osim.path), _PATH) for w in getattr(model, "warnings", [])],
            "instructions": frame.n_instructions()}
    return GaitFunctions(key, poses, frame, inverse.linear_system, meta, "built", False,
                         time.process_time() - clock, (model, eqs, joints))


def _save(fns: GaitFunctions) -> None:
    path = cache_file(fns.key)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps({"meta": fns.meta, "poses": fns.poses.serialize(), "frame": fns.frame.serialize(),
                               "system": fns.system.serialize()}))
    os.replace(tmp, path)       # atomic: a concurrent run sees no file or the whole file
    # keep the newest KEEP files: every edit of the builder's source or of a model makes a new
    # key (3-4 MB each for JW), and an old key is never asked for again
    old = sorted(path.parent.glob("gait_*.json"), key=lambda f: f.stat().st_mtime, reverse=True)[KEEP:]
    for f in old:
        try:
            f.unlink()
        except OSError:
            pass


def _load(key: str) -> GaitFunctions | None:
    path = cache_file(key)
    try:
        data = json.loads(path.read_text())
        if data["meta"].get("format") != FORMAT:
            return None
        return GaitFunctions(key, *(ca.Function.deserialize(data[k]) for k in ("poses", "frame", "system")),
                             data["meta"], "disk cache")
    except (OSError, ValueError, KeyError, RuntimeError):       # absent, half-written by an old version, damaged
        return None


def gait_functions(osim: OsimModel, compiled: str = "auto", cache: bool = True, frames: int = 0) -> GaitFunctions:
    """The frame functions of ``osim``: from this process's memory, the disk cache, or built (and saved).

    ``compiled``: ``"auto"`` (machine code when a compiled copy is cached, compiled now when
    ``frames`` reaches :data:`COMPILE_ABOVE_FRAMES`, else compiled in the background for later
    runs while this one uses the virtual machine), ``"always"`` (compile now if
    needed: about 6 s of CPU for a 24-body model, once) or ``"never"`` (CasADi's virtual
    machine). ``cache=False`` neither reads nor writes the disk cache.
    """
    if compiled not in ("auto", "always", "never"):
        raise GaitError(f"option 'compiled' must be 'auto', 'always' or 'never', got {compiled!r}")
    key = model_key(osim.path)
    fns = _MEMO.get(key)
    if fns is not None:
        fns.source = "memory"
    else:
        fns = _load(key) if cache else None
        if fns is None:
            fns = build_functions(osim, key)
            if cache:
                try:
                    _save(fns)
                except OSError as exc:     # a read-only cache only costs the next run the build
                    import sys
                    print(f"note: could not write the model cache {cache_file(key)} ({exc}); the next run builds "
                          "the model again", file=sys.stderr)
        _MEMO[key] = fns
    if compiled != "never" and not fns.compiled:
        from ..dynamics.compiled import compiled as machine_code

        # "auto" on a cache miss: this run on the virtual machine, the C compiled in the background for
        # the next runs (compiling costs 4-6 s of CPU, this run's frames through the VM far less)
        now = compiled == "always" or frames >= COMPILE_ABOVE_FRAMES
        code = machine_code(fns.frame, key=key, when_missing="now" if now else "background", what="the frame function")
        if code is not fns.frame:
            fns.compiled = True
            fns.frame = code
            fns._maps.clear()
    return fns


def quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)`` of rotation matrices ``R`` (``... x 3 x 3``), Shepperd's
    method branch for branch as :func:`ocp_constraints.mechanics.rotations.quaternion_from_rotation`."""
    R = np.asarray(R, float)
    tr = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    k = np.argmax(np.stack([tr, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1), axis=-1)
    out = np.empty(R.shape[:-2] + (4,))
    with np.errstate(invalid="ignore", divide="ignore"):     # each branch is used only where it is well defined
        s = [0.5 * np.sqrt(1 + tr), 0.5 * np.sqrt(1 + 2 * R[..., 0, 0] - tr),
             0.5 * np.sqrt(1 + 2 * R[..., 1, 1] - tr), 0.5 * np.sqrt(1 + 2 * R[..., 2, 2] - tr)]
        d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
        s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
        branches = [
            [s[0], d21 / (4 * s[0]), d02 / (4 * s[0]), d10 / (4 * s[0])],
            [d21 / (4 * s[1]), s[1], s01 / (4 * s[1]), s02 / (4 * s[1])],
            [d02 / (4 * s[2]), s01 / (4 * s[2]), s[2], s12 / (4 * s[2])],
            [d10 / (4 * s[3]), s02 / (4 * s[3]), s12 / (4 * s[3]), s[3]],
        ]
    for b in range(4):
        m = k == b
        for c in range(4):
            out[..., c][m] = branches[b][c][m]
    return np.where(out[..., :1] >= 0, out, -out)


__all__ = ["GaitFunctions", "gait_functions", "build_functions", "model_key", "cache_file", "quaternions"]
