"""Choices of ``ocp-constraints knee``, light enough for the CLI to read without importing the knee model."""
MUSCLE_MODELS = ("hill", "ideal")
METHODS = ("static", "collocation")
METHOD_TEXT = {"static": "static optimisation",
               "collocation": "direct collocation with activation dynamics over the gait cycle"}
