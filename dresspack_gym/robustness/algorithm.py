"""Algorithm 1 of the thesis (configuration robustness mapping) on the simulated robot and dresspack.

Configuration vector v = (Ry, j4, j5, j6) (eq. 4.8). Joints 1-3 move all cable nodes on link 3 as one
rigid unit, and only the pitch of link 3 changes the cable's shape (translations and rotations about
the vertical do not), so Ry is mapped onto the robot as the pitch of link 3, j2 + j3 = Ry, with j1 at
Home and j2 chosen to keep j3 inside its limits (Ry is taken modulo 360 deg into the pitch range of
joints 2 + 3). j4..j6 move the tool-plate node. Excursions that leave
a joint's range are clipped to it (the thesis moved free cable nodes, a real wrist stops at its limits).

Start states (``start``): with "row" (the default) the configurations of one grid row (the fastest axis,
j6, at fixed Ry, j4, j5) are mapped in order, each starting where the previous one ended (settled at the
previous v), as in the thesis's sequential loop; a row's first configuration starts from the settled
state of its Ry (cached per Ry). A row is one work unit, so a result depends only on the grid, never on
the backend, the worker count or an interruption. With "ry" every configuration starts from its Ry's
state (any single configuration can be mapped alone: samples, the path comparison).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..config import StationConfig
from ..errors import ConfigError
from ..simulation import CableSimulator
from ..station import Station

THESIS_EXCURSION = np.radians([20.0, 100.0, 100.0, 100.0])
START_MODES = ("row", "ry")


@dataclass(frozen=True)
class RobustnessSettings:
    """Options of Algorithm 1 and of its N-path extension."""

    excursion: tuple[float, float, float, float] = tuple(THESIS_EXCURSION)  # radians
    n_samples: int = 20  # N_s shape samples along the cable
    threshold: float = 0.1  # d_thresh [m]
    speed_fraction: float = 1.0  # of the rated joint speeds during excursions
    settle_time: float = 1.0  # max settle after each return [s]
    n_paths: int = 0  # 0: the thesis's two paths; K > 0: K random approach paths instead
    seed: int = 0  # for the random paths (combined with the configuration index)
    robot: int = 0
    # Mapping runs thousands of configurations. Against 1 ms / 1 ms on 80 random configurations of the
    # 24,336 grid, 4 ms motion steps agree on 95 % of robust flags with 8 ms or 16 ms relaxation steps
    # (2 ms: 99 %; 5 ms: 92.5 %; 6 ms: 89 %); 16 ms relaxation saves a quarter of the steps.
    timestep: float = 0.004  # [s] during motions
    settle_timestep: float = 0.016  # [s] while the robot stands still and the cable relaxes
    start: str = "row"  # "row": continue from the previous configuration of the grid row; "ry": from Ry's state

    def __post_init__(self):
        checks = {
            "excursion": (len(self.excursion) == 4 and all(0 <= e <= np.pi for e in self.excursion),
                          "four angles (Ry, j4, j5, j6) in [0, 180] deg"),
            "n_samples": (self.n_samples >= 2, "at least 2"),
            "threshold": (self.threshold > 0, "a positive distance [m]"),
            "speed_fraction": (0 < self.speed_fraction <= 1, "in (0, 1]"),
            "settle_time": (0 < self.settle_time <= 60, "in (0, 60] s"),
            "n_paths": (self.n_paths >= 0, "0 (the thesis's two paths) or a positive K"),
            "robot": (self.robot >= 0, "a robot index >= 0"),
            "timestep": (1e-4 <= self.timestep <= 0.01, "in [0.0001, 0.01] s"),
            "settle_timestep": (self.timestep <= self.settle_timestep <= 0.02, "in [timestep, 0.02] s"),
            "start": (self.start in START_MODES, f"one of {list(START_MODES)}"),
        }
        for name, (ok, allowed) in checks.items():
            if not ok:
                raise ConfigError(f"robustness.{name}", f"{getattr(self, name)!r} is not allowed: must be {allowed}")


def cable_only(config: StationConfig) -> StationConfig:
    """The station without obstacles, floor and weld points: the thesis maps the cable on its own."""
    return replace(config, obstacles=(), weld_points=(), floor=False)


def resample(points: np.ndarray, n: int) -> np.ndarray:
    """n points at equal arc length along a polyline (the N_s shape samples)."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(t, s, points[:, i]) for i in range(3)], axis=1)


class RobustnessEvaluator:
    """Evaluates configurations on one private simulator (one per worker process)."""

    def __init__(self, config: StationConfig, settings: RobustnessSettings):
        self.settings = settings
        if not 0 <= settings.robot < len(config.robots):
            raise ConfigError("robustness.robot", f"robot index {settings.robot} does not exist: the station has "
                                                  f"{len(config.robots)} robot(s)")
        config = cable_only(config)
        config = replace(config, simulation=replace(config.simulation, timestep=settings.timestep))
        self.station = Station(config)
        self.sim = CableSimulator(self.station)
        self.placement = self.station.config.robots[settings.robot]
        self.limits = self.placement.robot.joint_limits
        self._ry_states: dict[float, np.ndarray] = {}

    # ------------------------------------------------------------------------------ mapping
    def joints(self, v: np.ndarray) -> np.ndarray:
        """Robot joints (6,) for configuration vector v (4,), clipped to the joint limits."""
        lim = self.limits
        ry = float(v[0])
        lo_ry, hi_ry = lim[1, 0] + lim[2, 0], lim[1, 1] + lim[2, 1]
        if ry > hi_ry:  # a pitch is periodic: use the equivalent angle the arm can reach
            ry -= 2 * np.pi
        elif ry < lo_ry:
            ry += 2 * np.pi
        j3_mid = 0.5 * (lim[2, 0] + lim[2, 1])
        j2 = float(np.clip(ry - j3_mid, lim[1, 0], lim[1, 1]))
        j3 = ry - j2
        if not lim[2, 0] - 1e-9 <= j3 <= lim[2, 1] + 1e-9:
            lo, hi = np.degrees(lim[1, 0] + lim[2, 0]), np.degrees(lim[1, 1] + lim[2, 1])
            raise ConfigError("grid.ry", f"Ry = {np.degrees(ry):.1f} deg is outside the range the robot's joints 2 "
                                         f"and 3 can pitch link 3 to: [{lo:.0f}, {hi:.0f}] deg")
        q = np.array([self.placement.home[0], j2, j3, v[1], v[2], v[3]], dtype=float)
        return np.clip(q, lim[:, 0], lim[:, 1])

    def _all_robots(self, q: np.ndarray) -> np.ndarray:
        q_all = self.station.home.copy()
        q_all[self.settings.robot] = q
        return q_all

    def _start(self, ry: float) -> None:
        """Restore (or create once) the settled state with link 3 at pitch Ry and the wrist at zero."""
        key = round(ry, 12)
        if key not in self._ry_states:
            self.sim.reset(self._all_robots(self.joints(np.array([ry, 0.0, 0.0, 0.0]))), settle=False)
            self.sim.settle(3.0, timestep=self.settings.settle_timestep)
            self._ry_states[key] = self.sim.get_state()
        self.sim.set_state(self._ry_states[key])

    def _go(self, q: np.ndarray, settle: bool) -> None:
        self.sim.move_to(self._all_robots(q), speed_fraction=self.settings.speed_fraction, settle=False)
        if settle:
            self.sim.settle(self.settings.settle_time, timestep=self.settings.settle_timestep)

    def _shape(self) -> np.ndarray:
        return resample(self.sim.cable_points(self.settings.robot), self.settings.n_samples)

    # ------------------------------------------------------------------------------ Algorithm 1
    def evaluate_row(self, indices, configs) -> list[tuple[float, float]]:
        """Results for consecutive configurations of one grid row, each continuing from the previous one."""
        return [self.evaluate(i, v, continue_from_current=k > 0) for k, (i, v) in enumerate(zip(indices, configs))]

    def evaluate(self, index: int, v: np.ndarray, *, continue_from_current: bool = False) -> tuple[float, float]:
        """(max deviation of the negative path, of the positive path) [m] — thesis Algorithm 1, lines 3-12.

        Starts from the settled state of v's Ry, or (``continue_from_current``) from the simulator's
        current state. With ``n_paths = K > 0`` the two paths are replaced by K random ones: each moves
        to a uniformly random point of the excursion box around v and back; the second number is then 0.
        """
        s = self.settings
        if not continue_from_current:
            self._start(float(v[0]))
        q = self.joints(v)
        self._go(q, settle=True)
        s0 = self._shape()
        exc = np.asarray(s.excursion)
        if s.n_paths > 0:
            rng = np.random.default_rng([s.seed, index])
            devs = []
            for _ in range(s.n_paths):
                self._go(self.joints(v + rng.uniform(-1.0, 1.0, 4) * exc), settle=False)
                self._go(q, settle=True)
                devs.append(np.linalg.norm(self._shape() - s0, axis=1).max())
            return float(max(devs)), 0.0
        out = []
        for sign in (-1.0, 1.0):
            self._go(self.joints(v + sign * exc), settle=False)
            self._go(q, settle=True)
            out.append(float(np.linalg.norm(self._shape() - s0, axis=1).max()))
        return out[0], out[1]
