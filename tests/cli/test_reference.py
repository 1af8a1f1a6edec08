"""The command-line reference written from the parser: every subcommand a section, every argument a table row with
its help and default; and `dresspack --help` lists every subcommand."""

from __future__ import annotations

import argparse
import re

import pytest

from dresspack_gym.cli.args import add_station_argument
from dresspack_gym.cli.main import build_parser
from dresspack_gym.cli.reference import arguments, cli_reference_markdown, subcommands

PARSER = build_parser()
COMMANDS = subcommands(PARSER)
MARKDOWN = cli_reference_markdown()


def _sections(markdown: str) -> dict[str, str]:
    """Subcommand -> its section's text."""
    parts = re.split(r"^## dresspack (\S+)$", markdown, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2]))


def _cells(row: str) -> list[str]:
    """A table row's cells (``\\|`` is a pipe inside a cell)."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", row.strip())[1:-1]]


def test_every_subcommand_has_a_section_and_a_line_in_the_overview():
    sections = _sections(MARKDOWN)
    assert list(sections) == list(COMMANDS)
    assert {"plan", "eval", "train", "demo", "station-plan", "inspect", "bench"} <= set(sections)
    overview = MARKDOWN.split("\n## ", 1)[0]
    for name in COMMANDS:
        assert f"| `dresspack {name}` |" in overview
        assert f"usage: dresspack {name}" in sections[name]


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_argument_is_a_row_with_its_help_and_default(name):
    parser = COMMANDS[name][1]
    rows = [_cells(line) for line in _sections(MARKDOWN)[name].splitlines() if line.startswith("| `")]
    actions = arguments(parser)
    assert len(rows) == len(actions) and all(len(r) == 3 for r in rows), name
    for action, (argument, help_text, default) in zip(actions, rows):
        for spelling in action.option_strings or [action.metavar or action.dest]:
            assert f"`{spelling}" in argument, (name, spelling, argument)
        assert help_text, (name, argument)
        if action.required and not (not action.option_strings and action.nargs in ("?", "*")):
            assert default == "required"
        elif action.default not in (None, False, argparse.SUPPRESS):
            shown = action.default if not isinstance(action.default, (list, tuple)) else action.default[0]
            assert str(shown) in default, (name, argument, default)


def test_deprecated_spellings_are_marked():
    sections = _sections(MARKDOWN)
    assert "(deprecated: `--methods`)" in sections["eval"] and "(deprecated: `--tasks`)" in sections["eval"]
    assert "`STATION` (deprecated positional)" in sections["plan"]


def test_help_lines_are_expanded_and_table_safe():
    """%(default)s is expanded, and a help text holding a pipe or <angle brackets> keeps its row's three cells."""
    p = argparse.ArgumentParser(prog="dresspack")
    sub = p.add_subparsers(dest="command")
    x = sub.add_parser("x", help="a toy command for the table")
    add_station_argument(x)
    x.add_argument("--mode", default="a|b", help="one of a|b, written to <out>/mode.txt (default: %(default)s)")
    text = cli_reference_markdown(p)
    row = next(line for line in text.splitlines() if line.startswith("| `--mode"))
    assert _cells(row) == ["`--mode MODE`", "one of a\\|b, written to &lt;out&gt;/mode.txt (default: a\\|b)",
                           "`a\\|b`"]
    assert "(default: default)" in text


def test_dresspack_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(["--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0
    for name, (summary, _) in COMMANDS.items():
        assert re.search(rf"^\s+{re.escape(name)}\s", out, flags=re.M), name
        assert summary.split()[0] in out
