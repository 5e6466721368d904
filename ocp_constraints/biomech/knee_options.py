"""Choices of ``ocp-constraints knee``, light enough for the CLI to read without importing the knee model."""
MUSCLE_MODELS = ("hill", "ideal")
METHODS = ("static", "collocation")
#: the default (rule C17, written before the speed work: collocation once the whole command takes at most 5 s on
#: this machine and solves on all three JW trials; met on 2026-11-24, results/knee/preregistration.md)
METHOD_DEFAULT = METHODS[1]
METHOD_TEXT = {"static": "static optimisation",
               "collocation": "direct collocation with activation dynamics over the gait cycle"}
#: passive moments (Riener & Edrich 1999): the hip's (C5), the hip's, knee's and ankle's (C7), none
PASSIVE_HIP = ("riener-edrich-1999", "riener-edrich-1999-hip-knee-ankle", "none")
#: the default (candidate C7, adopted by the rule written before it was run: results/knee/preregistration.md)
PASSIVE_DEFAULT = PASSIVE_HIP[1]
#: the quadriceps' pull on the tibia: along each head's own path or through one patellar ligament (C13,
#: the default: adopted by the rule written before it was run, results/knee/preregistration.md)
QUADRICEPS = ("model-paths", "patellar-ligament")
QUADRICEPS_DEFAULT = QUADRICEPS[1]
