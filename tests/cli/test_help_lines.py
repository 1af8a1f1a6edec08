"""Every flag and argument of every command line says what it does, and every flag with a default shows it."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pytest

from dresspack_gym.cli.main import build_parser


def _commands():
    """(command, parser) of `dresspack` and each subcommand (those registered by entry points too: plan, eval,
    train, ...)."""
    main = build_parser()
    yield "dresspack", main
    sub = next(a for a in main._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        yield f"dresspack {name}", p


def _arguments():
    for command, parser in _commands():
        for a in parser._actions:
            if isinstance(a, (argparse._HelpAction, argparse._SubParsersAction)):
                continue
            yield command, parser, a


ARGUMENTS = list(_arguments())


def _name(action) -> str:
    return action.option_strings[0] if action.option_strings else action.dest


def _help(parser, action) -> str:
    """The help line as `--help` prints it (``%(default)s`` and the like expanded)."""
    return parser._get_formatter()._expand_help(action) if action.help else ""


def _mentions(text: str, default) -> bool:
    """Whether ``text`` shows ``default`` (a list: each of its items), in any of the usual spellings."""
    if isinstance(default, (list, tuple)):
        return all(_mentions(text, d) for d in default)
    if isinstance(default, bool):
        return str(default).lower() in text.lower()
    if isinstance(default, (int, float)):
        spellings = {str(default), f"{default:g}", f"{default:,}"}
        if isinstance(default, float) and math.isfinite(default) and default == int(default):
            spellings.add(str(int(default)))
        return any(s in text for s in spellings)
    return str(default) in text or (isinstance(default, Path) and f"{default}/" in text)


def test_the_walk_covers_every_command():
    commands = {c for c, _, _ in ARGUMENTS}
    assert {"dresspack inspect", "dresspack render", "dresspack robots", "dresspack animate", "dresspack bench",
            "dresspack plan", "dresspack demo", "dresspack station-plan", "dresspack select-model",
            "dresspack self-imitate", "dresspack eval", "dresspack train"} <= commands
    assert len(ARGUMENTS) > 150


@pytest.mark.parametrize("command,parser,action", ARGUMENTS, ids=[f"{c} {_name(a)}" for c, _, a in ARGUMENTS])
def test_every_argument_says_what_it_does_and_shows_its_default(command, parser, action):
    text = _help(parser, action)
    assert text.strip(), f"{command} {_name(action)}: no help line"
    default = action.default
    if default is None or default is False or default == argparse.SUPPRESS:
        return
    assert _mentions(text, default), f"{command} {_name(action)}: default {default!r} not shown in {text!r}"


def test_subcommands_say_what_they_do():
    main = build_parser()
    sub = next(a for a in main._actions if isinstance(a, argparse._SubParsersAction))
    helps = {c.dest: c.help for c in sub._choices_actions}
    assert set(helps) == set(sub.choices)
    for name, text in helps.items():
        assert text and len(text.split()) >= 4, f"dresspack {name}: {text!r} does not say what it does"
