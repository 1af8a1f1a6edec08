"""Grids of cable configuration vectors v = (Ry, j4, j5, j6) (thesis eq. 4.8), from YAML specs."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ConfigError
from ...fields import Section, check_vector

AXES = ("ry", "j4", "j5", "j6")
# A map costs ~1 s of one core per configuration (maps/README.md): 2 million is ~12 days on 2 cores, a day
# or two on a Ray cluster. Larger grids are refused before anything is allocated or written.
MAX_AXIS_VALUES = 10_000
MAX_CONFIGURATIONS = 2_000_000


def _axis(s: Section, key: str) -> np.ndarray:
    """An axis is {start, stop, step} (inclusive, thesis grid a) or {range: [lo, hi], count: n} (grid b)."""
    a = s.section(key)
    if a.has("step"):
        start = a.number("start", lo=-720, hi=720, unit="deg")
        stop = a.number("stop", lo=-720, hi=720, unit="deg")
        step = a.number("step", lo=0.0, lo_open=True, hi=720, unit="deg")
        a.done()
        if stop < start:
            raise ConfigError(a.field("stop"), f"stop {stop} must not be below start {start}")
        count = int(np.floor((stop - start) / step + 1e-9)) + 1
        if count > MAX_AXIS_VALUES:
            raise ConfigError(a.field("step"), f"gives {count:,} values on this axis; at most {MAX_AXIS_VALUES:,} "
                                               f"are allowed (use a larger step)")
        values = np.arange(start, stop + 1e-9, step)
    else:
        lo, hi = check_vector(a.raw("range"), a.field("range"), 2, lo=-720, hi=720, unit="deg")
        count = a.integer("count", lo=1, hi=MAX_AXIS_VALUES)
        endpoint = a.boolean("endpoint", False)
        a.done()
        if hi <= lo:
            raise ConfigError(a.field("range"), "upper end must exceed the lower end")
        if endpoint:
            values = np.linspace(lo, hi, count)
        else:  # `count` steps evenly spread around 0 over [lo, hi): the thesis test-case grid
            values = lo + (np.arange(count) + 0.5) * (hi - lo) / count
    return np.radians(values)


@dataclass(frozen=True)
class RobustnessGrid:
    """The product of four axes; row i of :meth:`configurations` is configuration index i."""

    name: str
    ry: np.ndarray
    j4: np.ndarray
    j5: np.ndarray
    j6: np.ndarray

    @property
    def shape(self) -> tuple[int, int, int, int]:
        return (len(self.ry), len(self.j4), len(self.j5), len(self.j6))

    def __len__(self) -> int:
        return int(np.prod(self.shape))

    def configurations(self) -> np.ndarray:
        """All configurations (N, 4) in radians, Ry slowest and j6 fastest."""
        mesh = np.meshgrid(self.ry, self.j4, self.j5, self.j6, indexing="ij")
        return np.stack([m.ravel() for m in mesh], axis=1)

    def nearest_index(self, v) -> np.ndarray:
        """Index of the nearest grid configuration for each v (N, 4) [rad]; angles compared on the circle."""
        v = np.atleast_2d(np.asarray(v, dtype=float))
        idx = []
        for k, axis in enumerate((self.ry, self.j4, self.j5, self.j6)):
            diff = np.abs((v[:, k, None] - axis[None, :] + np.pi) % (2 * np.pi) - np.pi)
            idx.append(np.argmin(diff, axis=1))
        return np.ravel_multi_index(tuple(idx), self.shape)

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str = "grid") -> RobustnessGrid:
        s = Section(data, path)
        name = s.string("name", "grid")
        axes = [_axis(s, k) for k in AXES]
        s.done()
        total = int(np.prod([len(a) for a in axes], dtype=object))
        if total > MAX_CONFIGURATIONS:
            raise ConfigError(path, f"{' x '.join(str(len(a)) for a in axes)} = {total:,} configurations; at most "
                                    f"{MAX_CONFIGURATIONS:,} are allowed (coarser steps or fewer counts)")
        return RobustnessGrid(name, *axes)
