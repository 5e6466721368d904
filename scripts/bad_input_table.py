"""Print the bad-input catalogue (issue 17) as the README's table, by running its cases.

The cases are those of ``tests/test_bad_input_catalogue.py`` (one test per class, parametrized over
the examples); each row is what the user does and what they get, as this code gives it now.

    python scripts/bad_input_table.py                    # Markdown table and a tally on stdout
    python scripts/bad_input_table.py --readme README.md # also write it into README.md between its markers
    PYTHONPATH=/tmp/old python scripts/bad_input_table.py --before   # the same cases against an older checkout

``--before`` measures what an older version gave (e.g. ``git archive <commit> | tar -x -C /tmp/old``): error
classes it did not have are stood in for by placeholders (so a case that expects one cannot pass), and the
class of runs beyond the machine is skipped (the old code would try them).

A case that comes back silent (no error, or a wrong result) or raw (an error that is not one of
``ocp_constraints.errors``, a traceback) is printed as such and the exit status is 1.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
START = "<!-- bad-input catalogue: written by `python scripts/bad_input_table.py --readme README.md` -->"
END = "<!-- end of the bad-input catalogue -->"


def _stub_missing_errors() -> None:
    """For --before: error classes an older version lacks become placeholders no real error is an instance of."""
    from ocp_constraints import errors

    for name in ("ResourceLimitError", "UsageError", "RunInterrupted"):
        if not hasattr(errors, name):
            setattr(errors, name, type(name, (errors.OcpConstraintsError,), {}))


def _catalogue():
    os.environ.setdefault("MPLBACKEND", "Agg")
    spec = importlib.util.spec_from_file_location("bad_input_catalogue", ROOT / "tests" / "test_bad_input_catalogue.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module     # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def _cell(text: str, limit: int = 230) -> str:
    text = re.sub(r"/tmp/tmp\w+", "<tmp>", " ".join(str(text).split())).replace("|", "\\|")
    return text if len(text) <= limit else text[: limit - 1].rstrip() + "…"


def classify(message: str) -> str:
    """``silent``, ``raw`` or ``unclear`` for a failed case's assertion message."""
    low = message.lower()
    if low.startswith("silent"):
        return "silent"
    if low.startswith("raw") or "traceback" in low:
        return "raw"
    return "unclear"


def table(module, skip: tuple[str, ...] = ()) -> tuple[str, dict[str, int]]:
    rows = ["| input class (before) | what the user does | what the user gets |", "|---|---|---|"]
    tally = {"cases": 0, "named": 0, "right result": 0, "silent": 0, "raw": 0, "unclear": 0}
    for key, (title, before, cases) in module.CATALOGUE.items():
        if key in skip:
            continue
        first = True
        for case in cases:
            tally["cases"] += 1
            try:
                got = module.outcome(case)
                tally["named" if isinstance(case.expect, (type, int)) else "right result"] += 1
            except AssertionError as exc:
                kind = "silent" if not isinstance(case.expect, (type, int)) else classify(str(exc))
                tally[kind] += 1
                got = f"**{kind.upper()}**: {exc}"
            except Exception as exc:  # noqa: BLE001 - a check's run raised something else: raw
                tally["raw"] += 1
                got = f"**RAW**: {type(exc).__module__}.{type(exc).__name__}: {exc}"
            label = f"**{title}** ({before})" if first else ""
            rows.append(f"| {label} | `{_cell(case.does, 120)}` | {_cell(got)} |")
            first = False
    n = tally
    summary = (f"{n['cases']} cases in {len(module.CATALOGUE)} classes: {n['named']} named errors (an "
               f"`ocp_constraints.errors` class, or exit 2 with one `error:` line), {n['right result']} inputs that "
               f"now give the right result; silent: {n['silent']}, raw: {n['raw']}, unclear: {n['unclear']}.")
    return "\n".join(rows) + "\n\n" + summary + "\n", tally


def write_readme(path: Path, text: str) -> None:
    readme = path.read_text()
    if START not in readme or END not in readme:
        raise SystemExit(f"{path} has no bad-input catalogue markers ({START} ... {END})")
    head, rest = readme.split(START, 1)
    _, tail = rest.split(END, 1)
    path.write_text(f"{head}{START}\n{text.rstrip()}\n{END}{tail}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--readme", type=Path, help="write the table into this README between its markers")
    p.add_argument("--before", action="store_true", help="run against an older version on PYTHONPATH (see above)")
    args = p.parse_args(argv)
    if args.before:
        _stub_missing_errors()
    text, tally = table(_catalogue(), skip=("resources",) if args.before else ())
    print(text)
    if args.readme:
        write_readme(args.readme, text)
    return 0 if tally["silent"] + tally["raw"] + tally["unclear"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
