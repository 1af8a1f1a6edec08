"""Query a robustness map: is a cable configuration (or a robot configuration) robust?"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .grid import RobustnessGrid
from .store import grid_from_meta, load_results, read_meta


def configuration_vector(q) -> np.ndarray:
    """v = (Ry, j4, j5, j6) (thesis eq. 4.8) of robot joints q (..., 6): Ry is link 3's pitch j2 + j3."""
    q = np.asarray(q, dtype=float)
    ry = (q[..., 1] + q[..., 2] + np.pi) % (2 * np.pi) - np.pi
    return np.concatenate([ry[..., None], q[..., 3:6]], axis=-1)


class RobustnessMap:
    """A finished (or partial) map; ``is_robust(v)`` answers from the nearest grid configuration.

    Unmeasured grid cells count as robust (a partial map only ever removes what it has shown to be bad).
    """

    def __init__(self, out: str | Path, grid: RobustnessGrid | None = None, threshold: float | None = None,
                 field: str = "robustness_map"):
        self.path = Path(out)
        meta = read_meta(out, field)
        self.grid = grid if grid is not None else grid_from_meta(meta)
        self.threshold = float(meta["settings"]["threshold"] if threshold is None else threshold)
        self.max_dev = np.full(len(self.grid), np.nan)
        for i, (_, dev, _) in load_results(out).items():
            if i < len(self.grid):
                self.max_dev[i] = dev

    @property
    def n_measured(self) -> int:
        return int(np.isfinite(self.max_dev).sum())

    def is_robust(self, v) -> np.ndarray:
        """(N,) bool for configuration vectors v (N, 4) [rad]."""
        dev = self.max_dev[self.grid.nearest_index(v)]
        return ~(dev >= self.threshold)

    def robust_joints(self, q) -> np.ndarray:
        """(N,) bool for robot joint vectors q (N, 6) [rad]."""
        return self.is_robust(configuration_vector(np.atleast_2d(q)))
