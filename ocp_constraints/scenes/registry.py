"""Scenes: a model with its initial state and defaults, built-in or from a user's file.

A scene module defines ``DESCRIPTION`` (one line), ``DEFAULTS`` (parameter name ->
value, SI units) and ``build(params) -> Scene``. Built-in scenes live in the
``problems`` package; any file with the same three names works when given by path.
"""
from __future__ import annotations

import importlib
import importlib.util
import math
import pkgutil
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

from ..errors import OcpConstraintsError, SceneError
from ..mechanics.model import Model


@dataclass
class Scene:
    """A model plus what a run needs: initial coordinates and rates, default horizon."""

    model: Model
    coordinates: dict[str, float]
    rates: dict[str, float]
    t_final: float = 10.0
    inputs: object = None
    notes: dict[str, str] = field(default_factory=dict)


def builtin_scene_names() -> list[str]:
    import problems

    return sorted(m.name for m in pkgutil.iter_modules(problems.__path__) if not m.name.startswith("_"))


def _load_file(path: Path) -> ModuleType:
    if not path.is_file():
        raise SceneError(f"scene file '{path}' does not exist")
    spec = importlib.util.spec_from_file_location(f"ocp_scene_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise SceneError(f"scene file '{exc.filename}', line {exc.lineno}: syntax error: {exc.msg}") from exc
    except Exception as exc:  # the user's code failed: show where
        frame = traceback.extract_tb(exc.__traceback__)[-1]
        raise SceneError(
            f"scene file '{path}' failed to load at {frame.filename}, line {frame.lineno}: "
            f"{type(exc).__name__}: {exc}"
        ) from exc
    return module


def load_scene_module(name_or_path: str) -> ModuleType:
    """The module of a built-in scene (by name) or of a scene file (by path)."""
    looks_like_path = name_or_path.endswith(".py") or "/" in name_or_path or "\\" in name_or_path
    if looks_like_path:
        module = _load_file(Path(name_or_path))
    else:
        names = builtin_scene_names()
        if name_or_path not in names:
            raise SceneError(
                f"unknown scene '{name_or_path}'. Built-in scenes: {', '.join(names)}; "
                "or give the path of a scene file (*.py)"
            )
        module = importlib.import_module(f"problems.{name_or_path}")
    missing = [a for a in ("DEFAULTS", "build") if not hasattr(module, a)]
    if missing:
        raise SceneError(
            f"scene '{name_or_path}' does not define {', '.join(missing)}: a scene module needs "
            "DESCRIPTION (one line), DEFAULTS (dict of parameters) and build(params) -> Scene"
        )
    return module


def resolve_parameters(scene: str, defaults: dict[str, float], overrides: dict[str, object]) -> dict[str, float]:
    """Defaults updated with overrides; unknown names and non-finite values are errors."""
    unknown = sorted(set(overrides) - set(defaults))
    if unknown:
        raise SceneError(
            f"scene '{scene}' has no parameter {', '.join(repr(u) for u in unknown)}; "
            f"its parameters are: {', '.join(sorted(defaults))}"
        )
    params = dict(defaults)
    for key, raw in overrides.items():
        try:
            value = float(raw)
        except (TypeError, ValueError):
            raise SceneError(f"scene '{scene}': parameter '{key}' must be a number, got {raw!r}") from None
        if not math.isfinite(value):
            raise SceneError(f"scene '{scene}': parameter '{key}' must be finite, got {raw!r}")
        params[key] = value
    return params


def build_scene(name_or_path: str, overrides: dict[str, object] | None = None) -> Scene:
    """Build a scene by name or path with parameter overrides (name -> value)."""
    module = load_scene_module(name_or_path)
    params = resolve_parameters(name_or_path, module.DEFAULTS, overrides or {})
    scene = _call_scene_code(name_or_path, "build(params)", module.build, params)
    if not isinstance(scene, Scene):
        raise SceneError(f"scene '{name_or_path}': build() must return a Scene, got {type(scene).__name__}")
    return scene


def build_task(name_or_path: str, task: str | None, overrides: dict[str, object] | None = None):
    """The optimal-control problem ``task`` of a scene (its ``TASKS`` table); default: the first."""
    module = load_scene_module(name_or_path)
    tasks = getattr(module, "TASKS", {})
    if not tasks:
        raise SceneError(f"scene '{name_or_path}' defines no optimal-control tasks (a TASKS table)")
    name = task or next(iter(tasks))
    if name not in tasks:
        raise SceneError(f"scene '{name_or_path}' has no task '{name}'; its tasks: {', '.join(tasks)}")
    params = resolve_parameters(name_or_path, module.DEFAULTS, overrides or {})
    return name, _call_scene_code(name_or_path, f"task '{name}'", tasks[name], params)


def _call_scene_code(scene: str, what: str, function, params: dict):
    """Run a scene's ``build`` or task function; its own failure becomes a :class:`SceneError`
    naming the scene, the file and line where it failed, and the parameters (our errors pass as they are)."""
    try:
        return function(params)
    except OcpConstraintsError:
        raise
    except Exception as exc:  # noqa: BLE001 - the scene's code failed: say where, as one line
        frames = traceback.extract_tb(exc.__traceback__)
        source = getattr(getattr(function, "__code__", None), "co_filename", None)
        own = [f for f in frames if f.filename == source] or frames[1:] or frames
        frame = own[-1]   # the deepest line of the scene's own file
        raise SceneError(
            f"scene '{scene}': {what} failed at {frame.filename}, line {frame.lineno}: {type(exc).__name__}: {exc}. "
            f"Check the scene's code and its parameters ({', '.join(f'{k}={v:g}' for k, v in params.items())})"
        ) from exc


def parse_param_arguments(items: list[str]) -> dict[str, str]:
    """``["name=value", ...]`` -> dict; a malformed item is an error naming it."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise SceneError(f"--param '{item}' must look like name=value")
        out[key.strip()] = value.strip()
    return out
