"""The command-line reference as Markdown, written from the ``dresspack`` parser (entry-point subcommands included)."""

from __future__ import annotations

import argparse

from .args import DeprecatedPositional, Renamed


def subcommands(parser: argparse.ArgumentParser) -> dict[str, tuple[str, argparse.ArgumentParser]]:
    """Name -> (one-line help, parser) of every subcommand of ``parser``, in the order ``--help`` lists them."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {c.dest: c.help or "" for c in sub._choices_actions}
    return {name: (helps.get(name, ""), p) for name, p in sub.choices.items()}


def arguments(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The arguments of ``parser`` a user gives (not ``--help``, not the subcommand choice)."""
    return [a for a in parser._actions if not isinstance(a, (argparse._HelpAction, argparse._SubParsersAction))]


def _invocation(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """How an argument is written: ``--planners NAME [NAME ...]``, ``--json``, ``STATION``; deprecated spellings
    named after it."""
    fmt = parser._get_formatter()
    if not action.option_strings:
        text = f"`{action.metavar or action.dest}{' ...' if action.nargs in ('*', '+') else ''}`"
        return text + (" (deprecated positional)" if isinstance(action, DeprecatedPositional) else "")
    name = action.option_strings[0]
    if action.nargs != 0:
        name += " " + fmt._format_args(action, fmt._get_default_metavar_for_optional(action))
    text = f"`{name}`"
    others = action.option_strings[1:]
    if others:
        label = "deprecated" if isinstance(action, Renamed) else "also"
        text += f" ({label}: {', '.join(f'`{o}`' for o in others)})"
    return text


def _default(action: argparse.Action) -> str:
    """The default value as given to argparse, or "required" (a positional that may be left out is not)."""
    if action.required and not (not action.option_strings and action.nargs in ("?", "*")):
        return "required"
    d = action.default
    if d is None or d is False or d == argparse.SUPPRESS:
        return ""
    if isinstance(d, (list, tuple)):
        d = " ".join(str(x) for x in d)
    return f"`{d}`"


def _escape(text: str) -> str:
    """A table cell: ``|`` escaped, and outside `code` spans ``<``/``>`` as entities (Markdown reads <x> as HTML)."""
    parts = text.replace("|", "\\|").replace("\n", " ").split("`")
    for i in range(0, len(parts), 2):
        parts[i] = parts[i].replace("<", "&lt;").replace(">", "&gt;")
    return "`".join(parts)


def _help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The help line as ``--help`` prints it (``%(default)s`` and the like expanded)."""
    return parser._get_formatter()._expand_help(action) if action.help else ""


def _section(name: str, summary: str, parser: argparse.ArgumentParser) -> list[str]:
    lines = [f"## dresspack {name}", "", _escape(summary[:1].upper() + summary[1:]) + ".", ""]
    if parser.description:
        lines += [_escape(parser.description), ""]
    lines += ["```text", parser.format_usage().strip(), "```", ""]
    rows = arguments(parser)
    if rows:
        lines += ["| argument | what it does | default |", "| --- | --- | --- |"]
        lines += [f"| {_invocation(parser, a)} | {_escape(_help(parser, a))} | {_escape(_default(a))} |" for a in rows]
        lines.append("")
    return lines


def cli_reference_markdown(parser: argparse.ArgumentParser | None = None) -> str:
    """Markdown of the ``dresspack`` command line (default: the installed parser, with the registered
    subcommands): a table of the subcommands, then one section per subcommand with its usage, description and a
    table of its arguments (the help lines with their defaults expanded, the default values, deprecated
    spellings)."""
    if parser is None:
        from .main import build_parser

        parser = build_parser()
    commands = subcommands(parser)
    lines = [f"`dresspack` has {len(commands)} subcommands; `dresspack SUBCOMMAND --help` prints the section below "
             "of each.", "", "| subcommand | what it does |", "| --- | --- |"]
    lines += [f"| `dresspack {name}` | {_escape(summary)} |" for name, (summary, _) in commands.items()]
    lines.append("")
    for name, (summary, p) in commands.items():
        lines += _section(name, summary, p)
    return "\n".join(lines).rstrip() + "\n"
