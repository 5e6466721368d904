"""What an export holds: its argument blocks and entries, its functions, and the report of a written export.

Plain data shared by the C text builders (:mod:`.c_text`), the round trip (:mod:`.verify`) and
:func:`ocp_constraints.codegen.export.export_model_c`, which fills them in.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from ..errors import ExportError
from ..mechanics.equations import SystemEquations

C_FLAGS = ("-Wall", "-Wextra", "-Werror", "-O2")   # the generated C compiles warning-free with these
TOLERANCE = 1e-12


@dataclass(frozen=True)
class Entry:
    """One entry of an argument: results-style ``name``, C macro ``key``, SI ``unit``."""

    name: str
    key: str
    unit: str
    description: str


@dataclass
class Block:
    """An argument or output of the exported functions (a dense ``double`` array)."""

    name: str
    title: str
    entries: list[Entry]

    @property
    def size(self) -> int:
        return len(self.entries)


@dataclass
class ExportedFunction:
    """One exported function: its reference CasADi Function and what it costs.

    ``inputs``/``outputs`` are block names in C argument order; ``n_operations`` counts
    the arithmetic instructions (no inputs, outputs or constants); ``code_bytes`` and
    ``code_lines`` measure its kernel in ``<p>_casadi.c``.
    """

    name: str
    casadi_name: str
    summary: str
    inputs: list[str]
    outputs: list[str]
    function: ca.Function
    n_instructions: int
    n_nodes: int
    n_operations: int
    code_bytes: int = 0
    code_lines: int = 0


@dataclass
class ExportReport:
    """What :func:`export_c` wrote: the folder, the functions, their layouts and sizes.

    ``sample`` holds the state the example program uses (block name -> values): the
    scene's consistent initial state at ``t = 0``, ``udot`` from the forward dynamics.
    ``files`` maps each written file to ``(bytes, lines)``.
    """

    scene: str
    prefix: str
    out_dir: Path
    parameters: dict[str, float]
    blocks: dict[str, Block]
    functions: list[ExportedFunction]
    sample: dict[str, np.ndarray]
    files: dict[str, tuple[int, int]] = field(default_factory=dict)
    round_trip: RoundTripReport | None = None
    eqs: SystemEquations | None = field(default=None, repr=False)

    @property
    def library_name(self) -> str:
        return f"lib{self.prefix}_constraints.so"

    @property
    def example_name(self) -> str:
        return f"{self.prefix}_example"

    @property
    def code_bytes(self) -> int:
        """Bytes of generated C (``.c`` and ``.h`` files)."""
        return sum(b for n, (b, _) in self.files.items() if n.endswith((".c", ".h")))

    @property
    def code_lines(self) -> int:
        return sum(n_l for n, (_, n_l) in self.files.items() if n.endswith((".c", ".h")))

    def function(self, suffix: str) -> ExportedFunction:
        """The exported function ``<prefix>_<suffix>`` (e.g. ``"multipliers"``)."""
        for f in self.functions:
            if f.name == f"{self.prefix}_{suffix}":
                return f
        raise ExportError(f"export of '{self.scene}' has no function '{suffix}'")

    def to_dict(self) -> dict:
        return {
            "scene": self.scene, "prefix": self.prefix, "casadi": ca.__version__, "parameters": self.parameters,
            "c_flags": list(C_FLAGS), "library": self.library_name, "example": self.example_name,
            "code": {"bytes": self.code_bytes, "lines": self.code_lines,
                     "files": {n: {"bytes": b, "lines": n_l} for n, (b, n_l) in self.files.items()}},
            "functions": [{"name": f.name, "casadi_name": f.casadi_name, "summary": f.summary, "inputs": f.inputs,
                           "outputs": f.outputs, "n_instructions": f.n_instructions, "n_nodes": f.n_nodes,
                           "n_operations": f.n_operations, "code_bytes": f.code_bytes, "code_lines": f.code_lines}
                          for f in self.functions],
            "layout": {b.name: {"title": b.title, "entries": [e.__dict__ for e in b.entries]} for b in self.blocks.values()},
            "sample": {k: np.asarray(v).ravel().tolist() for k, v in self.sample.items()},
            "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
        }


@dataclass
class RoundTripReport:
    """Largest relative errors of the compiled code against the CasADi evaluation.

    ``casadi_external`` and ``c_api`` map each function to its largest error over the
    random states (per state and output: max abs difference / max abs reference);
    ``example`` maps ``<function>.<output>`` to the error of the example's printout.
    """

    n_states: int
    seed: int
    compiler: str
    casadi_external: dict[str, float]
    c_api: dict[str, float]
    example: dict[str, float]
    compiler_output: str
    build_seconds: float
    tolerance: float = TOLERANCE

    @property
    def max_error(self) -> float:
        return max([*self.casadi_external.values(), *self.c_api.values(), *self.example.values()], default=0.0)

    @property
    def passed(self) -> bool:
        return self.max_error <= self.tolerance

    def to_dict(self) -> dict:
        return {"n_states": self.n_states, "seed": self.seed, "compiler": self.compiler, "tolerance": self.tolerance,
                "max_relative_error": self.max_error, "casadi_external": self.casadi_external, "c_api": self.c_api,
                "example": self.example, "build_seconds": self.build_seconds}
