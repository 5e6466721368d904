"""Defaults of ``ocp-constraints bench``, light enough for the CLI to read without importing the bench."""
DEFAULT_OUT = "results/bench"
QUICK_SCENES = ("pendulum", "sliding_cylinder", "sliding_disk")
