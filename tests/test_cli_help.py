"""Every option of every subcommand has help text, in plain text, and says its default.

The parser is walked as argparse built it (so a new option without ``help=`` fails here), and each
subcommand's ``--help`` is printed through the command's own entry point.
"""
from __future__ import annotations

import argparse
import re

import pytest

from ocp_constraints.cli.main import main, parser

MARKUP = re.compile(r"``|:(mod|func|class|meth):|\*\*")     # reStructuredText / Markdown in a help text


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _options(p: argparse.ArgumentParser):
    return [a for a in p._actions if not isinstance(a, (argparse._HelpAction, argparse._VersionAction))]


SUBCOMMANDS = sorted(_subcommands())


def test_every_subcommand_is_listed_with_help():
    action = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction))
    listed = {c.dest: c.help for c in action._choices_actions}
    assert sorted(listed) == SUBCOMMANDS
    assert all(listed.values()), [n for n, h in listed.items() if not h]


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_every_option_has_plain_help_that_gives_its_default(name):
    sub = _subcommands()[name]
    assert sub.description, f"'{name}' has no description for its --help"
    for a in _options(sub):
        label = f"{name} {'/'.join(a.option_strings) or a.dest}"
        assert a.help and a.help != argparse.SUPPRESS and len(a.help) > 10, f"{label}: no help text"
        assert not MARKUP.search(a.help), f"{label}: help is not plain text: {a.help!r}"
        if a.option_strings and a.default not in (None, False, [], argparse.SUPPRESS) and not a.required:
            assert "default" in a.help, f"{label}: default {a.default!r} not said in {a.help!r}"


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_help_prints_through_the_command(name, capsys):
    with pytest.raises(SystemExit) as stop:
        main([name, "--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith(f"usage: ocp-constraints {name}")
    for a in _options(_subcommands()[name]):
        assert (a.option_strings[0] if a.option_strings else (a.metavar or a.dest)) in text


def test_examples_in_help_keep_their_paths_whole(capsys):
    """An example's paths are printed unbroken (argparse would wrap them at hyphens)."""
    with pytest.raises(SystemExit):
        main(["gait", "--help"])
    text = capsys.readouterr().out
    assert "--model ../shared/data/opensim-gait2354-subject01/subject01_simbody.osim \\" in text
