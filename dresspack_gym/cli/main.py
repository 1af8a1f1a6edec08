"""The ``dresspack`` command line: the parser of the core subcommands and those packages register, and its errors."""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from pathlib import Path

from ..errors import DresspackError
from ..io.outputs import check_not_an_input
from .common import INTERRUPTED
from .figures import add_render, add_restrictions, add_twist_sweep
from .inspection import add_inspect
from .machine import add_bench, add_robots
from .maps import add_robustness_map, add_robustness_paths, add_wear_map
from .plans import add_animate, add_export
from .view import add_view_command


def registered_commands() -> list:
    """``add(subparsers)`` functions that packages built on this one register under the entry-point group
    ``dresspack.commands`` (``plan`` from dresspack.agents, ``demo`` from dresspack.eval): the core names none."""
    from importlib.metadata import entry_points

    return [ep.load() for ep in sorted(entry_points(group="dresspack.commands"), key=lambda ep: ep.name)]


class _Parser(argparse.ArgumentParser):
    """argparse, except that while :func:`main` runs with ``--json`` a usage error becomes a :class:`UsageError`,
    so scripts that asked for JSON get a JSON error object too."""

    json_errors = False

    def error(self, message):
        if _Parser.json_errors:
            raise UsageError(self.prog, message)
        super().error(message)


class UsageError(DresspackError):
    """A command line argparse refused (reported as JSON under ``--json``)."""

    def __init__(self, prog: str, message: str):
        self.field = message.split(":", 1)[0].removeprefix("argument ") if message.startswith("argument ") else ""
        super().__init__(f"{prog}: {message}")



# the core subcommands, in the order --help lists them (after those the packages built on the core register)
CORE_COMMANDS = (add_inspect, add_render, add_restrictions, add_robustness_map, add_robustness_paths,
                 add_twist_sweep, add_wear_map, add_robots, add_export, add_animate, add_view_command, add_bench)


def build_parser(extensions=None) -> argparse.ArgumentParser:
    """The ``dresspack`` parser with the core subcommands and ``extensions`` (default: the registered ones)."""
    p = _Parser(prog="dresspack", description="Robot dresspack wear simulation and planning.")
    sub = p.add_subparsers(dest="command", required=True)
    for add in registered_commands() if extensions is None else extensions:
        add(sub)
    for add in CORE_COMMANDS:
        add(sub)
    return p


def main(argv: list[str] | None = None, extensions=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    as_json = "--json" in argv  # every failure of a --json call is one JSON object on stdout, exit code 2
    _Parser.json_errors = as_json
    try:
        parser = build_parser(extensions)
        args = parser.parse_args(argv)
        args.argv = argv  # the command line as given: what an interrupted command prints to resume it
        check_not_an_input(*_outputs_and_inputs(parser, args))
        return args.func(args)
    except KeyboardInterrupt:
        # the long commands that save as they go say what they saved; every other one writes its files only at
        # its end (each whole: dresspack_gym.io.outputs), so an interrupt leaves nothing of its own behind
        print(f"\ninterrupted: nothing was saved; run it again with: dresspack {shlex.join(argv)}", file=sys.stderr)
        return INTERRUPTED
    except DresspackError as exc:
        if as_json:
            print(json.dumps({"error": str(exc), "field": getattr(exc, "field", "")}))
        else:
            print(f"error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader closed the pipe (`dresspack inspect default | head`): nothing is wrong and nothing more can be
        # written; point stdout at devnull so the interpreter's final flush does not raise again (Python's docs)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    finally:
        _Parser.json_errors = False


def _outputs_and_inputs(parser: argparse.ArgumentParser, args) -> tuple[list, list]:
    """(flag, path) of every output the command line names (the arguments of an output type: ``writes``) and of
    every other argument that names an existing file or folder (an input it may read)."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    outputs, inputs = [], []
    for action in sub.choices[args.command]._actions:
        value = getattr(args, action.dest, None)
        if value is None or action.dest in ("help", "command"):
            continue
        name = action.option_strings[0] if action.option_strings else action.dest
        values = value if isinstance(value, list) else [value]
        if getattr(action.type, "writes", None):
            outputs += [(name, Path(v)) for v in values]
        else:
            inputs += [(name, Path(v)) for v in values if isinstance(v, (str, Path)) and v and Path(v).exists()]
    return outputs, inputs


if __name__ == "__main__":
    sys.exit(main())
