"""Scenes: the registry that finds a built-in or user scene by name or path, and the tasks that run one
and write its results (uses mechanics, dynamics, ocp, output)."""
