"""The planner interface every method implements: station + task in, time-parameterised trajectory out."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from dresspack_gym.errors import ConfigError, DresspackError
from dresspack_gym.physics.trajectory import Trajectory
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task
from dresspack_gym.stations.validity import PLANNER_MARGIN, MotionValidity

from .budget import DEFAULT_EVALUATIONS, DEFAULT_ITERATIONS, DEFAULT_ROUTES, Allowance, Budget


class PlanningError(DresspackError):
    """No valid trajectory was found within the planning budget (or the task itself is invalid). ``field``, if
    given, names what to look at (e.g. ``robots.r1``), as a ConfigError does; the message then starts with it."""

    def __init__(self, message: str, field: str = ""):
        self.field = field
        super().__init__(f"{field}: {message}" if field else message)


@dataclass
class PlanResult:
    """A planner's answer: the trajectory, seconds of planning, and method-specific details."""

    trajectory: Trajectory
    planning_time: float
    method: str
    info: dict = field(default_factory=dict)


class Planner(ABC):
    """Base class: validates the task, seeds every random stream per plan, times the planning, checks the answer.

    Every plan starts from the planner's ``seed`` alone (:meth:`_reseed`), so a plan's result never depends on
    what the process planned before. ``iterations`` / ``evaluations`` / ``routes`` are the work budget
    (:class:`Budget`); ``time_budget`` is an optional wall-time cap [s] on top.
    """

    name = "planner"
    color = "#444444"  # the method's colour in reports
    uses_policy = False  # True: takes ``policy=`` (a trained policy's run folder, model or shipped name)

    def __init__(self, station: Station, robot: int = 0, *, time_budget: float | None = None,
                 iterations: int = DEFAULT_ITERATIONS, evaluations: int = DEFAULT_EVALUATIONS,
                 routes: int = DEFAULT_ROUTES, seed: int = 0,
                 margin: float = PLANNER_MARGIN, resolution_deg: float = 2.0):
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ConfigError("seed", f"must be an integer >= 0, got {seed!r}")
        self.station = station
        self.robot = robot
        self.budget = Budget(iterations, evaluations, routes, time_budget)
        self.seed = int(seed)
        self.validity = MotionValidity(station, robot, margin, resolution_deg)
        # the simulator's time law at the station's programmed speed: every method's motions are timed alike
        self.motion_limits = station.config.robots[robot].robot.joint_motion_limits.at_speed(
            station.config.simulation.speed_fraction)
        self.rng = np.random.default_rng(self.seed)
        self.allowance = Allowance(self.budget)

    @property
    def time_budget(self) -> float | None:
        return self.budget.wall_time

    def plan(self, task: Task) -> PlanResult:
        for name, q in [("start", task.start), *zip(task.weld_names, task.goals), ("home", task.end)]:
            if not self.validity.valid(q):
                raise PlanningError(f"task configuration {name!r} is invalid: {self.validity.why_invalid(q)}")
        self._reseed()
        self.validity.n_checks = 0
        self.allowance = Allowance(self.budget)
        traj, info = self._plan(task)
        elapsed = self.allowance.elapsed()
        if not self.validity.path_valid(traj.waypoints):
            raise PlanningError(f"{self.name} returned an invalid trajectory (a bug): please report it")
        info.setdefault("collision_checks", self.validity.n_checks)
        return PlanResult(traj, elapsed, self.name, info)

    def _reseed(self) -> None:
        """Restart every random stream of the method from ``seed`` (extended by methods with more streams)."""
        self.rng = np.random.default_rng(self.seed)

    def duration(self, traj: Trajectory) -> float:
        """Motion time [s] of a trajectory under the simulator's time law."""
        return float(traj.segment_durations(self.motion_limits).sum())

    @abstractmethod
    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        """Return the trajectory through the task's stops and a dict of details."""


def out_of_time_error(planner: Planner, what: str) -> PlanningError:
    return PlanningError(f"{planner.name}: wall-time cap of {planner.time_budget:g} s used up {what}")
