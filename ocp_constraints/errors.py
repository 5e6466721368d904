"""Every error the toolkit raises on purpose, in one place: each names the offending thing and what to do.

One base class, :class:`OcpConstraintsError`; a bad input is also a ``ValueError``, a run that did not
succeed also a ``RuntimeError``. The CLI prints any of them as one line (exit 2 for bad input, 1 for a
run that stopped)."""
from __future__ import annotations


class OcpConstraintsError(Exception):
    """Base class of every error this toolkit raises on purpose."""


class ModelError(OcpConstraintsError, ValueError):
    """A body, point, constraint, load or parameter is ill-formed."""


class NonAffineConstraintError(ModelError):
    """A constraint expression is not affine in the velocities (paper eq. 25)."""


class RedundantConstraintsError(ModelError):
    """The constraint Jacobian is rank deficient: some constraints repeat others."""


class InconsistentStateError(ModelError):
    """Initial coordinates or speeds violate the constraints."""


class UnknownColumnError(ModelError, KeyError):
    """A results table (e.g. ``sol.loads()``) has no column of that name; also a ``KeyError``, as a
    dict lookup's miss is, but with the message naming the closest columns."""

    def __str__(self) -> str:         # KeyError would print the message as a quoted repr
        return str(self.args[0]) if self.args else ""


class SceneError(OcpConstraintsError, ValueError):
    """A scene name, scene file or scene parameter is unusable."""


class UsageError(OcpConstraintsError, ValueError):
    """A command-line option is unusable or contradicts another (e.g. ``--degree`` without Radau)."""


class SimulationError(OcpConstraintsError, RuntimeError):
    """A forward simulation stopped early; ``partial`` holds what was computed."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


class JumpWindowWarning(UserWarning):
    """Values read inside a located jump of the inputs and multipliers (``OCPSolution.interpolate``): there
    they are only known at the points, and the error estimate does not cover them."""


class AmbiguousPoseWarning(UserWarning):
    """Initial or final values that two poses meet, each locally determined (one quaternion parameter of a hinged body
    fixed: ``theta`` or ``-theta``): IPOPT lands in either, depending on its start
    (:func:`~ocp_constraints.ocp.boundary_poses.ambiguous_boundary_poses`)."""


class QuaternionSignWarning(UserWarning):
    """A quaternion's initial and final values on opposite sheets (``q0 . qf < 0``): ``qf`` and ``-qf`` are one
    orientation, but the motion to ``qf`` turns a full turn more than the motion to ``-qf``."""


class SingularConfigurationError(ModelError):
    """An Euler-angle parameterization is at (or too near) its singularity."""


# -- optimal control

class OCPSolveError(OcpConstraintsError, RuntimeError):
    """IPOPT did not converge; ``solution`` holds the last iterate (``success`` False). The message also
    names what the last iterate violates most (``solution.violations()``: path constraints by label,
    bounds and boundary values by quantity), since IPOPT's 'Infeasible_Problem_Detected' names nothing."""

    def __init__(self, message: str, solution):
        super().__init__(message)
        self.solution = solution

    def __str__(self) -> str:
        # Read when printed (the violations cost evaluations); a caller may replace .solution after raising.
        cached = self.__dict__.get("_note")
        if cached is None or cached[0] is not self.solution:
            cached = self.__dict__["_note"] = (self.solution, _violation_note(self.solution))
        return super().__str__() + cached[1]


def _violation_note(solution) -> str:
    try:
        found = solution.violations(top=3)
    except Exception:  # no solution, or one that cannot be evaluated: the message as it was
        return ""
    if not found:
        return ""
    return "; most violated there: " + ", ".join(f"{what} by {amount:.3g} at t = {t:.3g} s" for what, amount, t in found)


# -- C export

class ExportError(OcpConstraintsError):
    """The C export cannot be written, built or verified."""


class CompilerNotFoundError(ExportError):
    """No C compiler: ``$CC`` names a program that does not exist, or none is installed."""


class CompilerError(ExportError):
    """The C compiler failed; the message includes the compiler's own output."""


class RoundTripError(ExportError):
    """The compiled code disagrees with the CasADi evaluation."""


# -- biomechanics: files, models, gait and knee

class DataFileError(OcpConstraintsError, ValueError):
    """A data file is missing, malformed, or does not hold what is asked of it."""

    def __init__(self, path, message: str, line: int | None = None, column: int | None = None):
        where = str(path)
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column {column}"
        super().__init__(f"{where}: {message}")
        self.path, self.line, self.column = str(path), line, column


class OsimModelError(ModelError):
    """An .osim file is unreadable or uses a feature this reader does not support."""


class GaitError(OcpConstraintsError, ValueError):
    """A trial cannot be processed: inconsistent files, unknown coordinates, no foot on a plate."""


class MuscleDataError(OcpConstraintsError, ValueError):
    """A muscle-path data file or a model's muscle parameters are missing or unusable."""


class ImplantGeometryError(OcpConstraintsError, ValueError):
    """The implant mesh files are missing or unusable."""


class KneeError(OcpConstraintsError, ValueError):
    """A knee-load computation cannot run: bad files, missing coordinates, solver failure."""


class KneeSolveError(KneeError):
    """IPOPT did not solve the knee's muscle-force problem; ``result`` holds its last iterate (``success``
    False, IPOPT's status), which ``ocp-constraints knee`` writes as such and exits 1."""

    def __init__(self, message: str, result):
        super().__init__(message)
        self.result = result


# -- resources and interruption

class ResourceLimitError(OcpConstraintsError, ValueError):
    """A run would need more memory than the machine has; the message carries the estimate."""

    def __init__(self, message: str, estimate=None):
        super().__init__(message)
        self.estimate = estimate


class RunInterrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived during a run (a ``KeyboardInterrupt``, so scripts stop as on Ctrl-C).

    ``signal_name`` is ``"SIGINT"`` or ``"SIGTERM"``; ``partial`` is set by the function that was
    interrupted to what it had computed (e.g. the trajectory up to the last complete sample)."""

    def __init__(self, signal_name: str = "SIGINT"):
        super().__init__(f"interrupted by {signal_name}")
        self.signal_name = signal_name
        self.partial = None


def interruption_reason(exc: BaseException) -> str:
    """``"interrupted by SIGINT"`` (or SIGTERM) for a ``KeyboardInterrupt`` from Ctrl-C or the CLI's handlers."""
    return f"interrupted by {getattr(exc, 'signal_name', 'SIGINT')}"


# -- batches

class BatchSpecError(OcpConstraintsError, ValueError):
    """A batch spec (file or sweep tables) is unusable."""
