"""ocp_constraints: constraint forces and constraint moments of rigid bodies.

A constraint is written as a CasADi expression ``pi = f . v_C + h . omega + e``; the
toolkit derives Lagrange's prescription ``F_c = lambda f`` at ``X_C``,
``M_c = lambda h`` (the paper's eq. 26), assembles the Newton-Euler equations and solves
them: forward simulation, inverse dynamics, direct-collocation optimal control, C export.

The public API is the names below, ``import ocp_constraints as oc; oc.Model(...)``. They are
loaded on first use (PEP 562), so the command line starts without importing CasADi.
"""
from __future__ import annotations

import importlib

from ._version import __version__
from .errors import (
    AmbiguousPoseWarning,
    CompilerError,
    CompilerNotFoundError,
    DataFileError,
    ExportError,
    GaitError,
    ImplantGeometryError,
    InconsistentStateError,
    JumpWindowWarning,
    KneeError,
    ModelError,
    MuscleDataError,
    NonAffineConstraintError,
    OCPSolveError,
    OcpConstraintsError,
    QuaternionSignWarning,
    OsimModelError,
    RedundantConstraintsError,
    ResourceLimitError,
    RoundTripError,
    RunInterrupted,
    SceneError,
    SimulationError,
    SingularConfigurationError,
    UsageError,
)

# public name -> module that defines it (relative to this package)
_PUBLIC = {
    "Model": "mechanics.model",
    "Body": "mechanics.bodies",
    "Point": "mechanics.bodies",
    "joints": "mechanics.joints",
    "EulerSequence": "mechanics.rotations",
    "UnitQuaternion": "mechanics.rotations",
    "quaternion_from_rotation": "mechanics.rotations",
    "SystemEquations": "mechanics.equations",
    "consistent_state": "mechanics.state",
    "SimulationOptions": "dynamics.simulate",
    "simulate": "dynamics.simulate",
    "Trajectory": "dynamics.trajectory",
    "InverseDynamics": "dynamics.inverse",
    "OptimalControlProblem": "ocp.problem",
    "Trapezoidal": "ocp.schemes",
    "HermiteSimpson": "ocp.schemes",
    "Radau": "ocp.schemes",
    "OCPSolution": "ocp.solution",
    "export_c": "codegen.export",
    "export_model_c": "codegen.export",
    "Scene": "scenes.registry",
    "build_scene": "scenes.registry",
    "build_task": "scenes.registry",
    "simulate_scene": "scenes.tasks",
    "load_urdf": "mechanics.urdf",
    "Robot": "mechanics.urdf_robot",
}

__all__ = sorted(_PUBLIC) + [name for name in dir() if name.endswith(("Error", "Warning"))] + ["RunInterrupted",
                                                                                              "__version__"]


def __getattr__(name: str):
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'ocp_constraints' has no attribute '{name}'")
    if name == "joints":
        value = importlib.import_module(f".{module}", __name__)
    else:
        value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
