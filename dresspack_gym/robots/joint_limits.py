"""The joint-limit rule: one tolerance, one check, one error message for every place that tests limits."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

# [rad] Configurations this far beyond a limit still count as inside: IK solutions and interpolated waypoints land
# on a limit up to rounding (e.g. +-2 pi turns of a joint whose limit is exactly 360 deg).
LIMIT_TOL = 1e-9


def within_limits(q, limits: np.ndarray) -> np.ndarray:
    """(N,) bool: which configurations q (N, 6) or (6,) lie within ``limits`` (6, 2) [rad], with ``LIMIT_TOL``."""
    q = np.atleast_2d(q)
    return np.all((q >= limits[:, 0] - LIMIT_TOL) & (q <= limits[:, 1] + LIMIT_TOL), axis=1)


def check_within_limits(q, limits: np.ndarray, field: str, digits: int = 2, owner: str = "") -> None:
    """A ConfigError naming ``field[j]`` for the first joint of ``q`` (6,) outside its limits (``owner``: e.g.
    " of robot 'r1'", appended to the message)."""
    q = np.asarray(q, dtype=float)
    bad = np.flatnonzero((q < limits[:, 0] - LIMIT_TOL) | (q > limits[:, 1] + LIMIT_TOL))
    if len(bad):
        j = int(bad[0])
        raise ConfigError(f"{field}[{j}]", f"{np.degrees(q[j]):.{digits}f} deg is outside joint {j + 1}'s "
                                           f"limits [{np.degrees(limits[j, 0]):.0f}, "
                                           f"{np.degrees(limits[j, 1]):.0f}] deg{owner}")
