"""Argument types of the command lines: ranged numbers, seeds and output paths, checked before any work starts.

argparse turns an ``ArgumentTypeError`` into ``error: argument --flag: <message>`` and exit code 2, so every
bad flag is refused at parse time, naming the flag and what it allows, before a station is even loaded.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

MAX_SEED = 2**32 - 1  # numpy's and OMPL's seed range


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, integer: bool = False,
           unit: str = ""):
    """An argparse ``type``: a finite float (or an int) in [lo, hi] (``lo_open``: (lo, hi])."""
    kind = "an integer" if integer else "a number"
    left = "(" if lo_open else "["
    allowed = f"{kind} in {left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]{' ' + unit if unit else ''}"

    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {kind}: must be {allowed}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text} is not allowed: must be {allowed}")
        below = lo is not None and (value <= lo if lo_open else value < lo)
        if below or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{text} is not allowed: must be {allowed}")
        return value

    parse.__name__ = "integer" if integer else "number"  # argparse names the type in its messages
    parse.bounds = (lo, hi, lo_open, integer)  # for tests that generate out-of-range values from a parser
    return parse


seed = number(0, MAX_SEED, integer=True)
positive_int = number(1, None, integer=True)


def _blocked_by_file(path: Path) -> Path | None:
    """The first existing ancestor of ``path`` that is a file (no folder can be made below it), if any."""
    for parent in path.resolve().parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def output_file(text: str) -> Path:
    """An argparse ``type`` for a file to write: not an existing folder, and its folder creatable.
    Missing parent folders are made by :func:`ensure_parent` when the file is written."""
    path = Path(text).expanduser()
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is an existing folder: give a file path")
    blocker = _blocked_by_file(path)
    if blocker is not None:
        raise argparse.ArgumentTypeError(f"cannot write {text!r}: {str(blocker)!r} is a file, not a folder")
    return path


def output_dir(text: str) -> Path:
    """An argparse ``type`` for an output folder (created if missing): not an existing file."""
    path = Path(text).expanduser()
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is an existing file: give a folder path")
    blocker = _blocked_by_file(path)
    if blocker is not None:
        raise argparse.ArgumentTypeError(f"cannot create {text!r}: {str(blocker)!r} is a file, not a folder")
    return path


def ensure_parent(path: str | Path) -> Path:
    """Make the folders above ``path`` (checked by :func:`output_file`), just before it is written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return path
