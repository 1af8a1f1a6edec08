"""Joint restrictions (thesis §4.1): cheap, vectorised rules on joint angles that avoid cable damage.

All rules take an array of configurations ``q`` of shape (N, 6) [rad] and return a boolean array of
shape (N,): True where the configuration is allowed. A :class:`RestrictionSet` is their conjunction
(thesis eq. 4.7).

Cable-support geometry (derived here, checked by brute force in tests/robots/test_restrictions.py).
In the wrist frame of link 4 (x along the forearm, origin at the wrist centre), the tip of a cable
support of length ``l`` mounted at distance ``m`` from the wrist centre on the tool plate, at angle ``p``
about the tool axis from joint 6's zero (right-handed about the flange x axis, i.e. clockwise seen from
the robot looking at the tool plate), is

    T = Ry(j5) Rx(j6) (m, -l sin p, l cos p) = (m c5 + L s5,  -l sin(phi),  -m s5 + L c5),
    phi = j6 + p,  L = l cos(phi).

So the support angle is ``j6 + p`` (the thesis text); the ``j6 - p`` printed in (4.3)/(4.4) is a sign slip.
The tip crushes the cable against link 4 when it is behind the wrist (T_x < 0) and closer than r + c
to the forearm axis. In the j5 plane, (T_x, T_z) is the vector (m, L) of length H = sqrt(m^2 + L^2)
turned by -j5, so the forbidden j5 form one interval centred on beta - pi, beta = atan2(L, m), of half
width asin(rho / H), rho^2 = (r + c)^2 - (l sin phi)^2. For L > 0 (zone A: cos(j6 + p) > 0) this is a
lower bound on j5, for L < 0 (zone B) an upper bound, and for phi = 0 it equals the thesis (4.3)
exactly: beta - pi + asin((r + c)/h) = -acos(l/h) - acos((r + c)/h).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..fields import Section, check_number

RESTRICTION_TYPES = ("twist_sum", "support_cylinder", "support_cuboid", "support_thesis_cylinder",
                     "support_thesis_cuboid")


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


@dataclass(frozen=True)
class TwistSum:
    """lower <= j4 + j6 - offset <= upper (thesis 4.1: |j4 + j6| <= 270 deg; 4.11: j4 + j6 >= 90 deg)."""

    lower: float = -math.inf
    upper: float = math.inf
    offset: float = 0.0

    def allowed(self, q: np.ndarray) -> np.ndarray:
        s = q[:, 3] + q[:, 5] - self.offset
        return (s >= self.lower) & (s <= self.upper)

    def describe(self) -> str:
        lo = "-inf" if math.isinf(self.lower) else f"{math.degrees(self.lower):g}"
        hi = "inf" if math.isinf(self.upper) else f"{math.degrees(self.upper):g}"
        off = f" - {math.degrees(self.offset):g}" if self.offset else ""
        return f"{lo} deg <= j4 + j6{off} <= {hi} deg"


@dataclass(frozen=True)
class SupportClearance:
    """j5 bounds as a function of j6 that keep the cable-support tip ``c`` away from link 4.

    ``shape``: "cylinder" (radius r, thesis 4.3/4.4) or "cuboid" (half-height r, half-width w, 4.5/4.6).
    ``model``: "exact" (the geometry above, exact for the idealised link) or "thesis" (the thesis's
    closed forms: cylinder a = r cos(j6 + p) + c over h = sqrt(m^2 + l^2); cuboid constant K).
    """

    r: float
    m: float
    l: float  # noqa: E741 - the thesis's name for the support length
    c: float
    p: float
    shape: str = "cylinder"
    w: float = math.inf
    model: str = "exact"

    def forbidden_interval(self, j6: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(centre, half width) of the forbidden j5 interval for each j6 (half width 0: no restriction)."""
        phi = np.asarray(j6) + self.p
        if self.model == "thesis":
            h = math.hypot(self.m, self.l)
            zone_a = np.cos(phi) >= 0
            if self.shape == "cylinder":
                a = np.where(zone_a, self.r * np.cos(phi), self.r * np.cos(phi + np.pi)) + self.c
            else:
                a = np.full_like(phi, self.r + self.c)
            beta = np.where(zone_a, math.atan2(self.l, self.m), -math.atan2(self.l, self.m))
            half = np.arcsin(np.clip(a / h, 0.0, 1.0))
            return _wrap(beta - np.pi), half
        lat = self.l * np.sin(phi)
        along = self.l * np.cos(phi)
        big_h = np.hypot(self.m, along)
        beta = np.arctan2(along, self.m)
        if self.shape == "cylinder":
            rho_sq = (self.r + self.c) ** 2 - lat ** 2
            rho = np.sqrt(np.maximum(rho_sq, 0.0))
            half = np.where(rho_sq > 0, np.arcsin(np.clip(rho / big_h, 0.0, 1.0)), 0.0)
        else:
            inside = np.abs(lat) < self.w + self.c
            half = np.where(inside, np.arcsin(np.clip((self.r + self.c) / big_h, 0.0, 1.0)), 0.0)
        return _wrap(beta - np.pi), half

    def allowed(self, q: np.ndarray) -> np.ndarray:
        centre, half = self.forbidden_interval(q[:, 5])
        return ~(np.abs(_wrap(q[:, 4] - centre)) < half)

    def j5_bounds(self, j6: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Allowed j5 range [lower, upper] inside (-pi, pi] per j6 (the thesis's f_A / f_B view)."""
        centre, half = self.forbidden_interval(j6)
        lower = np.where(half > 0, _wrap(centre + half), -np.pi)
        upper = np.where(half > 0, _wrap(centre - half), np.pi)
        return lower, upper

    def tip(self, q: np.ndarray) -> np.ndarray:
        """Support tip in the link-4 wrist frame, (N, 3): the geometry the rule protects."""
        j5, phi = q[:, 4], q[:, 5] + self.p
        along = self.l * np.cos(phi)
        return np.stack([self.m * np.cos(j5) + along * np.sin(j5), -self.l * np.sin(phi),
                         -self.m * np.sin(j5) + along * np.cos(j5)], axis=1)

    def describe(self) -> str:
        return (f"support {self.shape} ({self.model}): r={self.r} m, m={self.m} m, l={self.l} m, c={self.c} m, "
                f"p={math.degrees(self.p):g} deg")


@dataclass(frozen=True)
class RestrictionSet:
    """The conjunction (thesis 4.7) of any number of restrictions of one robot."""

    rules: tuple = ()

    def allowed(self, q) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q, dtype=float))
        ok = np.ones(len(q), dtype=bool)
        for rule in self.rules:
            ok &= rule.allowed(q)
        return ok

    def violated_by(self, q) -> list[str]:
        """Descriptions of the rules one configuration violates (for error messages)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))[:1]
        return [r.describe() for r in self.rules if not r.allowed(q)[0]]

    def __len__(self) -> int:
        return len(self.rules)

    @staticmethod
    def from_list(items: Any, path: str = "restrictions") -> "RestrictionSet":
        if items is None:
            return RestrictionSet()
        if not isinstance(items, list):
            raise ConfigError(path, "expected a list of restrictions")
        return RestrictionSet(tuple(restriction_from_dict(it, f"{path}[{i}]") for i, it in enumerate(items)))


def restriction_from_dict(data: Mapping[str, Any], path: str):
    s = Section(data, path)
    kind = s.string("type", choices=RESTRICTION_TYPES)
    if kind == "twist_sum":
        lower = s.raw("lower_deg", None)
        upper = s.raw("upper_deg", None)
        abs_max = s.raw("abs_max_deg", None)
        offset = math.radians(s.number("offset_deg", 0.0, lo=-720, hi=720, unit="deg"))
        s.done()
        if abs_max is not None:
            if lower is not None or upper is not None:
                raise ConfigError(f"{path}.abs_max_deg", "give either abs_max_deg or lower_deg/upper_deg, not both")
            v = math.radians(check_number(abs_max, f"{path}.abs_max_deg", lo=0, hi=1080, unit="deg"))
            return TwistSum(-v, v, offset)
        if lower is None and upper is None:
            raise ConfigError(path, "twist_sum needs abs_max_deg, lower_deg or upper_deg")
        lo = -math.inf if lower is None else math.radians(check_number(lower, f"{path}.lower_deg", lo=-1080,
                                                                                    hi=1080, unit="deg"))
        hi = math.inf if upper is None else math.radians(check_number(upper, f"{path}.upper_deg", lo=-1080,
                                                                                    hi=1080, unit="deg"))
        if lo > hi:
            raise ConfigError(path, "lower_deg must not exceed upper_deg")
        return TwistSum(lo, hi, offset)
    shape = "cylinder" if kind.endswith("cylinder") else "cuboid"
    model = "thesis" if "thesis" in kind else "exact"
    r = s.number("r", lo=0.0, lo_open=True, hi=2.0, unit="m")
    m = s.number("m", lo=0.0, lo_open=True, hi=2.0, unit="m")
    length = s.number("l", lo=0.0, lo_open=True, hi=2.0, unit="m")
    c = s.number("c", 0.0, lo=0.0, hi=1.0, unit="m")
    p = math.radians(s.number("p_deg", lo=-360, hi=360, unit="deg"))
    w = s.number("half_width", lo=0.0, lo_open=True, hi=2.0, unit="m") if shape == "cuboid" else math.inf
    s.done()
    return SupportClearance(r, m, length, c, p, shape, w, model)
