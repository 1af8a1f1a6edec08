"""Strict readers for plain-dict configuration: every error names the dotted field path."""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from .errors import ConfigError


class Section:
    """A view of one mapping in a config tree that hands out typed, range-checked fields.

    Call :meth:`done` after reading so that unknown (misspelled) keys are reported.
    """

    def __init__(self, data: Any, path: str):
        if not isinstance(data, Mapping):
            raise ConfigError(path, f"expected a mapping of keys to values, got {type(data).__name__}")
        self.data = dict(data)
        self.path = path
        self._used: set[str] = set()

    def field(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = ..., *, required: bool | None = None) -> Any:
        self._used.add(key)
        if key in self.data:
            return self.data[key]
        if default is ... or required:
            raise ConfigError(self.field(key), "is required but missing")
        return default

    def number(self, key: str, default: Any = ..., *, lo: float | None = None, hi: float | None = None,
               lo_open: bool = False, unit: str = "", hint: str = "") -> float:
        value = self.raw(key, default)
        return check_number(value, self.field(key), lo=lo, hi=hi, lo_open=lo_open, unit=unit, hint=hint)

    def integer(self, key: str, default: Any = ..., *, lo: int | None = None, hi: int | None = None) -> int:
        return check_integer(self.raw(key, default), self.field(key), lo=lo, hi=hi)

    def string(self, key: str, default: Any = ..., *, choices: Sequence[str] | None = None) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str):
            raise ConfigError(self.field(key), f"expected a string, got {value!r}")
        return value if choices is None else check_choice(self.field(key), value, choices)

    def boolean(self, key: str, default: Any = ...) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise ConfigError(self.field(key), f"expected true or false, got {value!r}")
        return value

    def vector(self, key: str, length: int, default: Any = ..., *, lo: float | None = None,
               hi: float | None = None, unit: str = "") -> tuple[float, ...]:
        value = self.raw(key, default)
        return check_vector(value, self.field(key), length, lo=lo, hi=hi, unit=unit)

    def section(self, key: str, default: Any = ...) -> "Section":
        value = self.raw(key, default)
        return Section(value, self.field(key))

    def sections(self, key: str, default: Any = ...) -> list["Section"]:
        value = self.raw(key, default)
        if not isinstance(value, list):
            raise ConfigError(self.field(key), f"expected a list, got {type(value).__name__}")
        return [Section(item, f"{self.field(key)}[{i}]") for i, item in enumerate(value)]

    def done(self) -> None:
        unknown = sorted(set(self.data) - self._used)
        if unknown:
            allowed = sorted(self._used)
            raise ConfigError(self.field(unknown[0]),
                              f"unknown key {unknown[0]!r}; allowed keys here are {allowed}")


def check_number(value: Any, field: str, *, lo: float | None = None, hi: float | None = None,
                 lo_open: bool = False, unit: str = "", hint: str = "") -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ConfigError(field, f"expected a number{' in ' + unit if unit else ''}, got {value!r}")
    value = float(value)
    left = "(" if lo_open else "["
    rng = f"{left}{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}]{' ' + unit if unit else ''}"
    if not math.isfinite(value):
        raise ConfigError(field, f"must be a finite number in {rng}, got {value}")
    below = lo is not None and (value <= lo if lo_open else value < lo)
    above = hi is not None and value > hi
    if below or above:
        msg = f"{value:g} is outside the allowed range {rng}"
        raise ConfigError(field, msg + (f" ({hint})" if hint else ""))
    return value


def check_integer(value: Any, field: str, *, lo: int | None = None, hi: int | None = None) -> int:
    """An integer (Python or numpy; not a bool, not 1.5) in [lo, hi]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ConfigError(field, f"expected an integer in [{lo}, {hi}], got {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ConfigError(field, f"{value} is outside the allowed range [{lo}, {hi}]")
    return int(value)


def check_vector(value: Any, field: str, length: int, *, lo: float | None = None, hi: float | None = None,
                 unit: str = "") -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise ConfigError(field, f"expected a list of {length} numbers{' in ' + unit if unit else ''}, got {value!r}")
    return tuple(check_number(v, f"{field}[{i}]", lo=lo, hi=hi, unit=unit) for i, v in enumerate(value))


def check_choice(field: str, value: Any, choices: Iterable) -> Any:
    """``value`` if it is one of ``choices``, else a ConfigError naming the field and the allowed values."""
    choices = list(choices)
    if value not in choices:
        raise ConfigError(field, f"{value!r} is not one of the allowed values {choices}")
    return value


def check_unique(names: Sequence[str], field: str, what: str) -> None:
    """Names that identify things must be unique: a repeated one would silently replace the first."""
    seen = set()
    for i, n in enumerate(names):
        if n in seen:
            raise ConfigError(f"{field}[{i}].name", f"{what} name {n!r} is used twice; {what} names must be unique")
        seen.add(n)
