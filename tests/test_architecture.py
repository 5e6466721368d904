"""The package's shape: imports run one way (README, "Architecture"), no cycle, small modules, and the
public API at the top level. Imports are read from the source (function-level ones included), so a
lazy import cannot hide an upward dependency."""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

import ocp_constraints as oc

PACKAGE = Path(oc.__file__).parent
# Lowest first: a module may import its own layer and the layers before it, never a later one.
LAYERS = ["errors", "_version", "output", "mechanics", "dynamics", "ocp", "scenes", "codegen", "biomech", "bench",
          "batch", "cli"]
PUBLIC = ["Model", "joints", "Body", "OptimalControlProblem", "Trapezoidal", "HermiteSimpson", "Radau", "simulate",
          "consistent_state", "InverseDynamics", "export_c", "build_scene", "simulate_scene", "SystemEquations",
          "SimulationOptions", "Scene", "OcpConstraintsError", "ModelError", "SimulationError", "OCPSolveError"]


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _imports(name: str, path: Path) -> set[str]:
    """Modules of the package that ``name`` imports (dotted, below the package), anywhere in its source."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1] if node.level > 1 else package
                stem = ".".join([p for p in base if p] + ([node.module] if node.module else []))
            elif (node.module or "").startswith("ocp_constraints"):
                stem = node.module.removeprefix("ocp_constraints").lstrip(".")
            else:
                continue
            found.update(f"{stem}.{a.name}".lstrip(".") for a in node.names)
            found.add(stem)
        elif isinstance(node, ast.Import):
            found.update(a.name.removeprefix("ocp_constraints").lstrip(".") for a in node.names
                         if a.name.startswith("ocp_constraints."))
    return {f for f in found if f}


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    graph = {}
    for name, path in mods.items():
        targets = set()
        for t in _imports(name, path):
            while t and t not in mods:
                t = t.rpartition(".")[0]
            if t and t != name and mods[t].name != "__init__.py":
                targets.add(t)
        graph[name] = targets
    return graph


def _layer(module: str) -> int:
    return LAYERS.index(module.split(".")[0])


def test_every_module_belongs_to_a_layer():
    stray = [m for m in _modules() if m and m.split(".")[0] not in LAYERS + ["__main__"]]
    assert not stray, f"modules outside the layers of the README's Architecture: {stray}"


def test_imports_run_one_way_down_the_layers():
    upward = [f"{m} -> {t}" for m, ts in _graph().items() if m and m != "__main__"
              for t in ts if _layer(t) > _layer(m)]
    assert not upward, "imports against the layer order: " + "; ".join(sorted(upward))


def test_no_import_cycle_even_through_function_level_imports():
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in sorted(graph.get(m, ())):
            if state.get(t) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(t):] + [t]))
            if t not in state:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)


def test_modules_stay_small():
    big = {m: n for m, p in _modules().items() if (n := len(p.read_text().splitlines())) > 420}
    assert not big, f"modules over ~400 lines (split them by idea): {big}"


@pytest.mark.parametrize("name", PUBLIC)
def test_public_name_importable_from_the_top_level(name):
    assert getattr(oc, name) is not None


def test_command_line_help_imports_neither_casadi_nor_the_bench():
    code = ("import sys; from ocp_constraints.cli.main import parser; parser().format_help(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('casadi', 'scipy', 'matplotlib') "
            "or (m.startswith('ocp_constraints.bench.') and m != 'ocp_constraints.bench.defaults')))")
    # bench.defaults holds two constants for the bench's --help text, nothing else
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]", f"--help imported {out}"
