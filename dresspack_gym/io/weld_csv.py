"""Weld lists from CSV files as spreadsheets and CAD/OLP tools write them: one weld point per row, each error named
by row and column."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ..errors import ConfigError

REQUIRED = ("name", "x", "y", "z", "approach_x", "approach_y", "approach_z")
OPTIONAL = ("robot", "spin_min_deg", "spin_max_deg", "spin_step_deg")
LENGTH_UNITS = {"m": 1.0, "mm": 0.001}
DELIMITERS = (",", ";")  # ";" is what a spreadsheet writes where "," is the decimal separator
MAX_BYTES = 16 * 2 ** 20  # a weld list of a whole body in white is well under a megabyte
MAX_ROWS = 100_000
SPIN_LIMIT_DEG = 360.0  # a spin range lies within one turn either way (as a YAML weld point's spin_deg)
MAX_SPINS = 721  # one per degree over the whole [-360, 360]: each spin is solved for every IK branch of the weld


def read_weld_rows(path: Path, field: str, units: str) -> list[tuple[str, dict]]:
    """``[(where, weld point dict for weld_point_from_section)]`` of the CSV at ``path`` (lengths in ``units``),
    ``where`` naming the row (``field[file:row n]``). UTF-8 with or without a byte-order mark, ``,`` or ``;``
    between cells, LF or CRLF line ends; rows whose cells are all empty are skipped; every other problem is a
    ConfigError naming the row and column."""
    text = _decode(path, field)
    lines = text.splitlines()
    header_line = next((line for line in lines if line.strip()), "")
    delimiter = _delimiter(header_line)
    rows = list(csv.reader(io.StringIO(text, newline=""), delimiter=delimiter))
    if not rows or not any(c.strip() for c in rows[0]):
        raise ConfigError(field, f"{path.name} is empty: expected a header row with columns {list(REQUIRED)}")
    header = [c.strip() for c in rows[0]]
    missing = [c for c in REQUIRED if c not in header]
    unknown = [c for c in header if c not in REQUIRED + OPTIONAL]
    repeated = sorted({c for c in header if header.count(c) > 1})
    if missing or unknown or repeated:
        problems = ([f"missing columns {missing}"] if missing else []) + \
                   ([f"unknown columns {unknown}"] if unknown else []) + \
                   ([f"columns given twice {repeated}"] if repeated else [])
        raise ConfigError(field, f"{path.name}: {'; '.join(problems)}; columns are {list(REQUIRED)} plus optional "
                                 f"{list(OPTIONAL)}, separated by ',' or ';'")
    if len(rows) - 1 > MAX_ROWS:
        raise ConfigError(field, f"{path.name} has {len(rows) - 1} rows, more than {MAX_ROWS}")
    scale = LENGTH_UNITS[units]
    out = []
    for n, cells in enumerate(rows[1:], start=2):  # row 1 is the header
        if not any(c.strip() for c in cells):
            continue
        where = f"{field}[{path.name}:row {n}]"
        if len(cells) != len(header):
            raise ConfigError(where, f"has {len(cells)} cells, the header {len(header)} ({', '.join(header)}): "
                                     f"a cell too many or too few (a '{delimiter}' inside a value must be quoted)")
        row = dict(zip(header, (c.strip() for c in cells)))
        out.append((where, _weld(row, where, scale, delimiter)))
    if not out:
        raise ConfigError(field, f"{path.name} has a header but no weld rows")
    return out


def _decode(path: Path, field: str) -> str:
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise ConfigError(field, f"{path.name} is {size} bytes, more than a weld list's {MAX_BYTES}")
    data = path.read_bytes()
    try:
        return data.decode("utf-8-sig")  # a spreadsheet's "CSV UTF-8" starts with a byte-order mark
    except UnicodeDecodeError as exc:
        line_start = data.rfind(b"\n", 0, exc.start) + 1
        row = data.count(b"\n", 0, exc.start) + 1
        before = data[line_start:exc.start]
        cell = max(before.count(b","), before.count(b";")) + 1
        raise ConfigError(f"{field}[{path.name}:row {row}]",
                          f"byte 0x{data[exc.start]:02x} in cell {cell} is not UTF-8: save the file as "
                          f"'CSV UTF-8' (the text encoding of every weld list)") from None


def _delimiter(header_line: str) -> str:
    """The delimiter that splits the header into known column names (a header holds no decimal commas)."""
    best = max(DELIMITERS, key=lambda d: sum(c.strip() in REQUIRED + OPTIONAL for c in header_line.split(d)))
    return best


def _weld(row: dict, where: str, scale: float, delimiter: str) -> dict:
    def num(col, default=None):
        text = row.get(col, "")
        if text == "" and default is not None:
            return default
        value = text.replace(",", ".") if delimiter == ";" and text.count(",") == 1 and "." not in text else text
        try:
            x = float(value)
        except ValueError:
            raise ConfigError(f"{where}.{col}", f"{text!r} is not a number") from None
        if not math.isfinite(x):
            raise ConfigError(f"{where}.{col}", f"{text!r} is not a finite number")
        return x

    if not row["name"]:
        raise ConfigError(f"{where}.name", "is empty: every weld point needs a name")
    data = {"name": row["name"], "pos": [num(c) * scale for c in ("x", "y", "z")],
            "approach": [num(f"approach_{a}") for a in "xyz"]}
    if row.get("robot"):
        data["robot"] = row["robot"]
    if row.get("spin_min_deg") or row.get("spin_max_deg"):
        data["spin_deg"] = _spins(num("spin_min_deg", 0.0), num("spin_max_deg", 0.0), num("spin_step_deg", 30.0),
                                  where)
    return data


def _spins(lo: float, hi: float, step: float, where: str) -> list[float]:
    """The candidate spins lo, lo + step, ... <= hi [deg], their number bounded before any is made."""
    for col, v in (("spin_min_deg", lo), ("spin_max_deg", hi)):
        if abs(v) > SPIN_LIMIT_DEG:
            raise ConfigError(f"{where}.{col}", f"{v:g} is outside [{-SPIN_LIMIT_DEG:g}, {SPIN_LIMIT_DEG:g}] deg")
    if not (step > 0 and hi >= lo):
        raise ConfigError(f"{where}.spin_max_deg", f"spin range [{lo}, {hi}] step {step}: needs "
                                                   "spin_max_deg >= spin_min_deg and a step > 0")
    count = math.floor((hi - lo) / step + 1e-9) + 1
    if count > MAX_SPINS:
        raise ConfigError(f"{where}.spin_step_deg", f"spin range [{lo:g}, {hi:g}] deg in steps of {step:g} deg gives "
                                                    f"{count} candidate spins, more than {MAX_SPINS}: take a larger "
                                                    f"step")
    return (lo + step * np.arange(count)).tolist()
