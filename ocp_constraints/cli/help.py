"""Plain-text help for every subcommand: wrapped descriptions, examples kept line by line.

argparse wraps every text it prints, which breaks a long example command (a path split at a
hyphen cannot be pasted). :class:`HelpFormatter` wraps descriptions as usual but prints an epilog
that starts with ``example`` exactly as written; :func:`example` writes one command over several
lines with shell continuations.
"""
from __future__ import annotations

import argparse

DATA = "../shared/data"
GAIT = f"{DATA}/opensim-gait2354-subject01"
JW = f"{DATA}/grand-challenge-knee-jw"
JW_MODEL = f"{JW}/reducepoly_model/JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
JW_TRIAL = f"{JW}/reducepoly_subject_GC"


class HelpFormatter(argparse.HelpFormatter):
    """Descriptions wrapped to the terminal; an ``example`` epilog printed as written."""

    def _fill_text(self, text, width, indent):
        if text.startswith("example"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def example(command: str, *options: str) -> str:
    """An epilog: ``command`` then one option per line, joined by shell line continuations."""
    return "example (from the repository's folder):\n  " + " \\\n      ".join([command, *options])
