"""Arguments of the command lines: ranged numbers, seeds, output paths and ``--station``, and deprecated spellings.

argparse turns an ``ArgumentTypeError`` into ``error: argument --flag: <message>`` and exit code 2, so every
bad flag is refused at parse time, naming the flag and what it allows, before a station is even loaded.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

MAX_SEED = 2**32 - 1  # numpy's and OMPL's seed range

MAX_JOBS = 64
ALL_CORES = min(os.cpu_count() or 1, MAX_JOBS)  # every --jobs flag's default: one process per core


def add_physics_argument(parser, what: str, default: str | None = None) -> None:
    """``--physics {dynamic,fast}``: the cable engine ``what`` runs on (default: profiles.DEFAULT_ENGINE)."""
    from ..physics.profiles import DEFAULT_ENGINE, ENGINE_TITLES, ENGINES

    default = DEFAULT_ENGINE if default is None else default
    parser.add_argument("--physics", choices=list(ENGINES), default=default,
                        help=f"the cable engine {what}: " + ", ".join(f"{k} = {v}" for k, v in ENGINE_TITLES.items())
                             + " (default: %(default)s)")


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, integer: bool = False,
           unit: str = ""):
    """An argparse ``type``: a finite float (or an int) in [lo, hi] (``lo_open``: (lo, hi])."""
    kind = "an integer" if integer else "a number"
    left = "(" if lo_open or lo is None else "["
    right = "inf)" if hi is None else f"{hi}]"  # an open end: infinity itself is no value
    allowed = f"{kind} in {left}{'-inf' if lo is None else lo}, {right}{' ' + unit if unit else ''}"

    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {kind}: must be {allowed}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text} is not allowed: must be finite, {allowed}")
        below = lo is not None and (value <= lo if lo_open else value < lo)
        if below or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{text} is not allowed: must be {allowed}")
        return value

    parse.__name__ = "integer" if integer else "number"  # argparse names the type in its messages
    parse.bounds = (lo, hi, lo_open, integer)  # for tests that generate out-of-range values from a parser
    return parse


seed = number(0, MAX_SEED, integer=True)
positive_int = number(1, None, integer=True)


def _output_type(folder: bool, suffixes: tuple[str, ...] = ()):
    """An argparse ``type`` for a path a command writes (``folder``: a folder it writes in): checked before any
    work by the one owner of outputs (dresspack_gym.io.outputs): of the right kind, a suffix the writer writes,
    its folder creatable and taking new files. Marked ``writes``: :func:`main` also refuses it when it names an
    input."""

    def parse(text: str) -> Path:
        from ..io.outputs import output_problem

        path = Path(text).expanduser()
        problem = output_problem(path, folder=folder, suffixes=suffixes)
        if problem is not None:
            raise argparse.ArgumentTypeError(f"{text!r} {problem}" if problem.startswith("is an existing")
                                             else f"cannot {'create' if folder else 'write'} {text!r}: {problem}")
        return path

    parse.__name__ = "folder" if folder else "file"
    parse.writes = "folder" if folder else "file"
    return parse


def file_to_write(*suffixes: str):
    """An argparse ``type`` for a file a command writes, in one of ``suffixes`` (any if none); missing parent
    folders are made when it is written."""
    return _output_type(False, tuple(s.lower() for s in suffixes))


output_file = file_to_write()  # a file to write, any suffix
output_dir = _output_type(True)  # an output folder, made if missing


def ensure_parent(path: str | Path) -> Path:
    """Make the folders above ``path`` (checked by :func:`output_file`), just before it is written. The commands
    write through dresspack_gym.io.outputs.replacing instead, which also writes the file whole and removes the
    folders it made when the writer fails."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


# ------------------------------------------------------------------------------------- deprecated spellings
def warn_deprecated(message: str) -> None:
    """The one line on stderr a deprecated spelling prints: it still works for one release."""
    print(f"dresspack: {message}", file=sys.stderr)


def _given_as(parser, namespace, dest: str, name: str, spelling: str) -> None:
    """Remember that ``dest`` was given as ``spelling``; refuse it if another spelling of ``name`` gave it already."""
    given = namespace.__dict__.setdefault("_given_as", {})
    first = given.setdefault(dest, spelling)
    if first != spelling:
        parser.error(f"argument {name}: given both as {first} and as {spelling}; give {name} only")


class Renamed(argparse.Action):
    """argparse's ``store`` for a flag that has deprecated spellings: its first option string is its name, every
    further one (``add_argument("--planners", "--methods", action=Renamed, ...)``) a deprecated spelling that still
    works for one release and prints one line to stderr when used. A value given by two spellings is refused."""

    def __call__(self, parser, namespace, values, option_string=None):
        name = self.option_strings[0]
        _given_as(parser, namespace, self.dest, name, option_string)
        if option_string != name:
            warn_deprecated(f"{option_string} is deprecated; use {name}")
        setattr(namespace, self.dest, values)


class DeprecatedPositional(argparse.Action):
    """A positional argument kept for one release as the deprecated spelling of the flag ``flag`` (a
    :class:`Renamed` flag of the same dest): given, it prints one line to stderr and stores its value as the flag
    would; given beside the flag, it is refused."""

    def __init__(self, option_strings, dest, flag: str, what: str, **kwargs):
        super().__init__(option_strings, dest, **kwargs)
        self.flag, self.what = flag, what

    def __call__(self, parser, namespace, values, option_string=None):
        _given_as(parser, namespace, self.dest, self.flag, f"the positional {self.metavar}")
        warn_deprecated(f"the positional {self.what} is deprecated; use {self.flag} NAME")
        setattr(namespace, self.dest, values)


STATION_HELP = "station YAML file or shipped station name (default: %(default)s)"


def add_station_argument(parser, help: str = STATION_HELP, *, default: str | None = "default",
                         required: bool = False, deprecated_positional: bool = False) -> None:
    """``--station NAME_OR_YAML``, the one spelling of a command's station (``default``: the station used when the
    flag is not given), and where the command took the station as its positional argument before, that positional
    as a deprecated spelling (``deprecated_positional``)."""
    if required and deprecated_positional:
        raise ValueError("a required --station cannot have a positional spelling: argparse would demand the flag")
    parser.add_argument("--station", action=Renamed, default=default, required=required, metavar="NAME_OR_YAML",
                        help=help)
    if deprecated_positional:
        parser.add_argument("station", nargs="?", default=argparse.SUPPRESS, action=DeprecatedPositional,
                            flag="--station", what="station", metavar="STATION",
                            help="deprecated: the station as a positional argument (works for one release); "
                                 "use --station")
