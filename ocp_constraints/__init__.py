"""ocp_constraints: constraint forces and constraint moments of rigid bodies.

A constraint is written as a CasADi expression ``pi = f . v_C + h . omega + e``; the
toolkit derives Lagrange's prescription ``F_c = lambda f`` at ``X_C``,
``M_c = lambda h`` (the paper's eq. 26), assembles the
Newton-Euler equations and solves them.
"""
from .model import Model
from .equations import SystemEquations
from .state import consistent_state
from .simulate import SimulationOptions, simulate
from .scenes import Scene, build_scene

__version__ = "0.1.0"

__all__ = ["Model", "SystemEquations", "consistent_state", "SimulationOptions", "simulate", "Scene", "build_scene", "__version__"]
