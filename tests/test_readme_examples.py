"""Every ``ocp-constraints`` command in README.md's code blocks runs as written.

The commands are read from the README itself (fenced blocks other than ``text``/``python``; lines
joined at ``\\`` continuations; several commands on a line split at ``&&``); bash expands the shell
variables the block assigns (``A="--model $M ..."``) exactly as a reader's shell would. Each command
then runs through the command's entry point from the repository's folder (the data paths are
``../shared/data/...``), with only its ``--out`` moved to a temporary folder; it must exit 0 and,
where it writes results, leave a successful ``summary.json`` (and ``report.html`` unless
``--no-plots``). Identical commands run once.

Skipped, with the reason, only what takes minutes: a ``batch`` of many runs (its machinery has its
own tests in test_batch.py), the ``bench`` (test_bench_report.py) and the knee's collocation on the
full 120 Hz cycle (the same command on a 30 Hz cycle is in test_knee_collocation.py).
"""
from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

from ocp_constraints.cli.main import main

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
FENCE = re.compile(r"^(\s*)```(\w*)\s*$")
#: command prefix -> why it is not run here (each takes minutes; measured on this 2-core machine)
SLOW = {
    "ocp-constraints batch": "a batch of many runs (the README's knee sensitivity batch: 15 knee runs, 97 s of CPU); "
                             "the batch command itself is tested in test_batch.py",
    "ocp-constraints bench --readme": "the full benchmark (about 6 min); tested in test_bench_report.py",
    "ocp-constraints bench --quick": "41 s of CPU, 2 min 51 s of wall time under load; tested in test_bench_report.py",
}


def _blocks(text: str) -> list[tuple[str, list[str]]]:
    out, cur, lang, indent = [], None, "", ""
    for line in text.splitlines():
        m = FENCE.match(line)
        if m and cur is None:
            cur, lang, indent = [], m.group(2), m.group(1)
        elif m and cur is not None:
            out.append((lang, cur))
            cur = None
        elif cur is not None:
            cur.append(line[len(indent):] if line.startswith(indent) else line.lstrip())
    return out


def _argv(assignments: list[str], command: str) -> list[str]:
    """The command's words after bash's expansion of the block's variables."""
    script = "\n".join(assignments + [f"set -- {command}", 'printf "%s\\0" "$@"'])   # a line each: comments end there
    out = subprocess.run(["bash", "-c", script], capture_output=True, text=True, check=True).stdout
    return out.split("\0")[:-1]


def readme_commands() -> list[tuple[str, list[str]]]:
    """(the command as written, its argv) for every ``ocp-constraints`` command of README.md's code blocks."""
    found: list[tuple[str, list[str]]] = []
    for lang, lines in _blocks(README.read_text()):
        if lang in ("text", "python", "toml", "json"):
            continue
        assignments: list[str] = []
        for line in "\n".join(lines).replace("\\\n", " ").splitlines():
            s = line.strip()
            if re.match(r"^[A-Za-z_]\w*=", s):
                assignments.append(s)
            for segment in s.split("&&"):
                segment = segment.strip()
                if segment.startswith("ocp-constraints "):
                    found.append((re.sub(r"\s+", " ", segment), _argv(assignments, segment)))
    return found


def _unique() -> list[tuple[str, list[str]]]:
    seen, out = set(), []
    for written, argv in readme_commands():
        key = tuple(a for i, a in enumerate(argv) if i == 0 or argv[i - 1] != "--out")
        if key not in seen:
            seen.add(key)
            out.append((written, argv))
    return out


COMMANDS = _unique()


def test_the_readme_has_gait_and_knee_examples_with_real_paths():
    argvs = [argv for _, argv in readme_commands()]
    for name in ("gait", "knee"):
        runs = [a for a in argvs if a[1] == name]
        assert runs, f"no '{name}' example in the README's code blocks"
        for a in runs:
            for opt in ("--model", "--motion", "--grf"):
                path = a[a.index(opt) + 1]
                assert (REPO / path).resolve().is_file(), f"{' '.join(a)}: {opt} {path} does not exist"


@pytest.mark.parametrize("written, argv", COMMANDS, ids=[w[16:60] for w, _ in COMMANDS])
def test_readme_command_runs_as_written(written, argv, tmp_path, monkeypatch):
    slow = next((why for prefix, why in SLOW.items() if written.startswith(prefix)), None)
    if slow:
        pytest.skip(f"not run here: {slow}")
    assert argv[0] == "ocp-constraints"
    args = list(argv[1:])
    out = None
    if "--out" in args:
        out = tmp_path / "out"
        args[args.index("--out") + 1] = str(out)
    monkeypatch.chdir(REPO)
    assert main(args) == 0, written
    if out is not None and (out / "summary.json").is_file():
        summary = json.loads((out / "summary.json").read_text())
        assert summary.get("success", True) is True, written
        if "--no-plots" not in args:
            assert (out / "report.html").is_file(), written
