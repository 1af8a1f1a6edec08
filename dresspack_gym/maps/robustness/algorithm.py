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

Quasi-static by construction (the thesis's cable simulation is static): every stored shape S0, S1, S2
is a settled equilibrium proven by its residual, and every excursion is slow enough that the net force
on every cable vertex (its acceleration, averaged over a few steps) stays below ``max_dynamic_ratio``
of its weight; a configuration
whose excursions exceed it is re-run from the same start at half the speed, down to
``min_speed_fraction``. A configuration whose stored shape never reaches equilibrium (e.g. a cable
jammed against a link) is reported as unconverged, not as a sample. Cable-robot contact is off by default, as in the
thesis, which maps the cable with its nodes moved alone (``cable_robot_contact``: the cable rests on and is pushed by
the robot's links; on either engine a third or more of the configurations then end unconverged or jammed,
docs/robustness.md).

Engines (``engine``, one of physics.profiles.ENGINES): "dynamic" (MuJoCo, the default:
physics.profiles.DEFAULT_ENGINE) or "fast" (the quasi-static rod engine, dresspack_gym.rod). Both see the same
station: with ``cable_robot_contact`` off the dresspack's ``collide_with_robot`` is cleared, which removes the robot's own links
from MuJoCo's contacts and from the rod engine's barrier primitives alike. On the fast engine a settle is the rod's
static rest solve, the excursions are the same slowed time law with one implicit step per 0.05 s sample, and a
configuration is unconverged when a rest solve or a motion step missed its tolerance or a link jammed against the
cable (``jammed``: a sample the links did not get through in the engine's sub-step budget).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...errors import ConfigError
from ...physics.profiles import DEFAULT_ENGINE, ENGINES, make_simulator
from ...robots.joint_limits import LIMIT_TOL
from ...stations.config import StationConfig
from ...stations.station import Station

THESIS_EXCURSION = np.radians([20.0, 100.0, 100.0, 100.0])
START_MODES = ("row", "ry")


@dataclass(frozen=True)
class RobustnessSettings:
    """Options of Algorithm 1 and of its N-path extension."""

    excursion: tuple[float, float, float, float] = tuple(THESIS_EXCURSION)  # radians
    n_samples: int = 20  # N_s shape samples along the cable
    threshold: float = 0.1  # d_thresh [m]
    # Quasi-static defaults from scripts/studies/robustness_settings_study.py (100 random configurations of the
    # 67,500 grid against 1/8 speed with 2/8 ms steps): rated speed agrees on 92 % of flags, half speed 94 %,
    # these 98 % (quarter speed first, halved while any vertex accelerates above 0.5 g).
    speed_fraction: float = 0.25  # the full-speed excursion slowed to this fraction in time (first try)
    settle_time: float = 5.0  # max settle after each return [s]; settles end on the equilibrium residual
    max_dynamic_ratio: float = 0.5  # bound on the cable's vertex accelerations / g during excursions
    min_speed_fraction: float = 1.0 / 16.0  # the slowest excursion speed tried
    cable_robot_contact: bool = False  # the thesis's cable alone (True: the cable against the robot's links)
    n_paths: int = 0  # 0: the thesis's two paths; K > 0: K random approach paths instead
    seed: int = 0  # for the random paths (combined with the configuration index)
    robot: int = 0
    # Mapping runs thousands of configurations. Against 1 ms / 1 ms on 80 random configurations of the
    # 24,336 grid, 4 ms motion steps agree on 95 % of robust flags with 8 ms or 16 ms relaxation steps
    # (2 ms: 99 %; 5 ms: 92.5 %; 6 ms: 89 %); 16 ms relaxation saves a quarter of the steps.
    timestep: float = 0.004  # [s] during motions
    settle_timestep: float = 0.016  # [s] while the robot stands still and the cable relaxes
    start: str = "row"  # "row": continue from the previous configuration of the grid row; "ry": from Ry's state
    engine: str = DEFAULT_ENGINE  # the cable engine (physics.profiles.ENGINES): "dynamic" (MuJoCo) or "fast"

    def __post_init__(self):
        checks = {
            "excursion": (len(self.excursion) == 4 and all(0 <= e <= np.pi for e in self.excursion),
                          "four angles (Ry, j4, j5, j6) in [0, 180] deg"),
            "n_samples": (self.n_samples >= 2, "at least 2"),
            "threshold": (0 < self.threshold <= 10, "a distance in (0, 10] m"),
            "speed_fraction": (0 < self.speed_fraction <= 1, "in (0, 1]"),
            "settle_time": (0 < self.settle_time <= 60, "in (0, 60] s"),
            "max_dynamic_ratio": (0 < self.max_dynamic_ratio <= 1000, "in (0, 1000] (vertex acceleration / g)"),
            "min_speed_fraction": (0 < self.min_speed_fraction <= self.speed_fraction,
                                   "in (0, speed_fraction]"),
            "n_paths": (self.n_paths >= 0, "0 (the thesis's two paths) or a positive K"),
            "robot": (self.robot >= 0, "a robot index >= 0"),
            "timestep": (1e-4 <= self.timestep <= 0.01, "in [0.0001, 0.01] s"),
            "settle_timestep": (self.timestep <= self.settle_timestep <= 0.02, "in [timestep, 0.02] s"),
            "start": (self.start in START_MODES, f"one of {list(START_MODES)}"),
            "engine": (self.engine in ENGINES, f"one of {list(ENGINES)}"),
        }
        for name, (ok, allowed) in checks.items():
            if not ok:
                raise ConfigError(f"robustness.{name}", f"{getattr(self, name)!r} is not allowed: must be {allowed}")


def cable_only(config: StationConfig, robot_contact: bool = False) -> StationConfig:
    """The station without obstacles, floor and weld points (the thesis maps the cable on its own), and
    without cable-robot contact unless ``robot_contact``."""
    robots = tuple(replace(r, dresspack=replace(r.dresspack, collide_with_robot=r.dresspack.collide_with_robot
                                                and robot_contact)) for r in config.robots)
    return replace(config, obstacles=(), weld_points=(), floor=False, robots=robots)


@dataclass(frozen=True)
class ConfigurationResult:
    """One configuration's outcome: deviations of the two paths [m] (the second 0 with K paths), whether
    every stored shape was a converged equilibrium, the largest vertex acceleration / g of the excursions
    finally used and their speed fraction."""

    dev_neg: float
    dev_pos: float
    converged: bool
    dynamic_ratio: float
    speed_fraction: float
    jammed: bool = False  # fast engine: a link jammed against the cable in some sample (then also unconverged)


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
        config = cable_only(config, settings.cable_robot_contact)
        config = replace(config, simulation=replace(config.simulation, timestep=settings.timestep,
                                                    settle_timestep=settings.settle_timestep))
        self.station = Station(config)
        self.sim = make_simulator(self.station, settings.engine)
        self.fast = settings.engine == "fast"
        self.placement = self.station.config.robots[settings.robot]
        self.limits = self.placement.robot.joint_limits
        self._ry_states: dict[float, np.ndarray] = {}

    # ------------------------------------------------------------------------------ mapping
    def pitch(self, ry: float) -> float:
        """Ry taken modulo 360 deg into the pitch range joints 2 + 3 can give link 3."""
        lim = self.limits
        lo_ry, hi_ry = lim[1, 0] + lim[2, 0], lim[1, 1] + lim[2, 1]
        if ry > hi_ry:  # a pitch is periodic: use the equivalent angle the arm can reach
            ry -= 2 * np.pi
        elif ry < lo_ry:
            ry += 2 * np.pi
        return ry

    def joints(self, v: np.ndarray, delta: np.ndarray | None = None) -> np.ndarray:
        """Robot joints (6,) for configuration vector v (4,) moved by ``delta`` (an excursion), clipped to
        the joint limits. The excursion is added after Ry is wrapped into the arm's pitch range, so an
        excursion never sends link 3 the long way round (Ry near the range's ends)."""
        lim = self.limits
        ry = self.pitch(float(v[0]))
        if delta is not None:
            lo_ry, hi_ry = lim[1, 0] + lim[2, 0], lim[1, 1] + lim[2, 1]
            ry = float(np.clip(ry + delta[0], lo_ry, hi_ry))
            v = np.asarray(v, dtype=float) + delta
        j3_mid = 0.5 * (lim[2, 0] + lim[2, 1])
        j2 = float(np.clip(ry - j3_mid, lim[1, 0], lim[1, 1]))
        j3 = ry - j2
        if not lim[2, 0] - LIMIT_TOL <= j3 <= lim[2, 1] + LIMIT_TOL:
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
            self._settle(3.0)
            self._ry_states[key] = self.sim.get_state()
        self.sim.set_state(self._ry_states[key])

    def _settle(self, max_time: float) -> bool:
        """Let the cable come to rest (MuJoCo: relax for at most ``max_time``; rod engine: its rest solve)."""
        if self.fast:
            return self.sim.settle().converged
        return self.sim.settle(max_time, timestep=self.settings.settle_timestep).converged

    def _go(self, q: np.ndarray, settle: bool, speed: float) -> tuple[float, bool]:
        """Move to q; returns (max vertex acceleration / g of the motion, settled to equilibrium or not settling)."""
        if self.fast:
            trace = self.sim.move_quasi_static(self._all_robots(q), speed_fraction=speed)
        else:
            trace = self.sim.move_to(self._all_robots(q), speed_fraction=speed, settle=False, quasi_static=True)
        converged = self._settle(self.settings.settle_time) if settle else True
        return trace.max_acceleration_ratio, converged

    def _shape(self) -> np.ndarray:
        return resample(self.sim.cable_points(self.settings.robot), self.settings.n_samples)

    # ------------------------------------------------------------------------------ Algorithm 1
    def evaluate_row(self, indices, configs) -> list[ConfigurationResult]:
        """Results for consecutive configurations of one grid row, each continuing from the previous one."""
        return [self.evaluate(i, v, continue_from_current=k > 0) for k, (i, v) in enumerate(zip(indices, configs))]

    def evaluate(self, index: int, v: np.ndarray, *, continue_from_current: bool = False) -> ConfigurationResult:
        """Thesis Algorithm 1, lines 3-12, quasi-static: the deviations of the negative and positive paths.

        Starts from the settled state of v's Ry, or (``continue_from_current``) from the simulator's
        current state. With ``n_paths = K > 0`` the two paths are replaced by K random ones: each moves
        to a uniformly random point of the excursion box around v and back; the second number is then 0.
        If an excursion is too fast (a cable vertex accelerating above ``max_dynamic_ratio`` g), the whole
        configuration is redone from the same start state at half the speed.
        """
        s = self.settings
        if not continue_from_current:
            self._start(float(v[0]))
        start = self.sim.get_state()
        speed = s.speed_fraction
        while True:
            self.sim.set_state(start)
            jams, misses = self._flags()
            last = speed <= s.min_speed_fraction * (1 + 1e-9)
            devs, ratio, converged = self._paths(index, v, speed, stop_above=None if last else s.max_dynamic_ratio)
            jams_after, misses_after = self._flags()
            jammed = jams_after > jams
            converged = converged and not jammed and misses_after == misses
            if ratio <= s.max_dynamic_ratio or last:
                return ConfigurationResult(devs[0], devs[1], converged, ratio, speed, jammed)
            speed = max(speed / 2.0, s.min_speed_fraction)

    def _flags(self) -> tuple[int, int]:
        """The fast engine's running counts of jammed samples and unconverged motion steps (MuJoCo: none)."""
        return (self.sim.jammed_samples, self.sim.unconverged_steps) if self.fast else (0, 0)

    def _paths(self, index: int, v: np.ndarray, speed: float, stop_above: float | None = None
               ) -> tuple[tuple[float, float], float, bool]:
        """The paths' deviations, the largest vertex acceleration / g of their excursions and whether every stored
        shape converged. ``stop_above``: give up (deviations 0, not converged) at the first excursion move whose
        ratio exceeds it: the caller redoes the configuration slower, so the rest of this attempt could not change
        the result."""
        s = self.settings
        q = self.joints(v)
        _, converged = self._go(q, True, speed)
        s0 = self._shape()
        exc = np.asarray(s.excursion)
        ratio = 0.0
        if s.n_paths > 0:
            rng = np.random.default_rng([s.seed, index])
            deltas = [rng.uniform(-1.0, 1.0, 4) * exc for _ in range(s.n_paths)]
        else:
            deltas = [-exc, exc]
        devs = []
        for delta in deltas:
            out_ratio, _ = self._go(self.joints(v, delta), False, speed)
            if stop_above is not None and out_ratio > stop_above:
                return (0.0, 0.0), out_ratio, False
            back_ratio, ok = self._go(q, True, speed)
            ratio = max(ratio, out_ratio, back_ratio)
            if stop_above is not None and ratio > stop_above:
                return (0.0, 0.0), ratio, False
            converged &= ok
            devs.append(float(np.linalg.norm(self._shape() - s0, axis=1).max()))
        if s.n_paths > 0:
            return (max(devs), 0.0), ratio, converged
        return (devs[0], devs[1]), ratio, converged
