"""The planner interface every method implements: station + task in, time-parameterised trajectory out."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

from dresspack_gym.errors import DresspackError
from dresspack_gym.station import Station
from dresspack_gym.tasks import Task
from dresspack_gym.trajectory import Trajectory
from dresspack_gym.validity import MotionValidity


class PlanningError(DresspackError):
    """No valid trajectory was found within the planning budget (or the task itself is invalid)."""


@dataclass
class PlanResult:
    """A planner's answer: the trajectory, seconds of planning, and method-specific details."""

    trajectory: Trajectory
    planning_time: float
    method: str
    info: dict = field(default_factory=dict)


class Planner(ABC):
    """Base class: validates the task, times the planning, checks the answer."""

    name = "planner"

    def __init__(self, station: Station, robot: int = 0, *, time_budget: float = 20.0, seed: int = 0,
                 margin: float = 0.005, resolution_deg: float = 2.0):
        if time_budget <= 0:
            raise PlanningError(f"time_budget must be positive, got {time_budget}")
        self.station = station
        self.robot = robot
        self.time_budget = float(time_budget)
        self.seed = int(seed)
        self.validity = MotionValidity(station, robot, margin, resolution_deg)
        self.joint_speed = station.config.robots[robot].robot.joint_speed
        self.speed_fraction = station.config.simulation.speed_fraction

    def plan(self, task: Task) -> PlanResult:
        for name, q in [("start", task.start), *zip(task.weld_names, task.goals), ("home", task.end)]:
            if not self.validity.valid(q):
                raise PlanningError(f"task configuration {name!r} is invalid: {self.validity.why_invalid(q)}")
        t0 = time.perf_counter()
        self.deadline = t0 + self.time_budget
        traj, info = self._plan(task)
        elapsed = time.perf_counter() - t0
        if not self.validity.path_valid(traj.waypoints):
            raise PlanningError(f"{self.name} returned an invalid trajectory (a bug): please report it")
        info.setdefault("collision_checks", self.validity.n_checks)
        return PlanResult(traj, elapsed, self.name, info)

    def remaining(self) -> float:
        return max(0.0, self.deadline - time.perf_counter())

    def duration(self, traj: Trajectory) -> float:
        """Motion time [s] of a trajectory under the simulator's time law."""
        return float(traj.segment_durations(self.joint_speed, self.speed_fraction).sum())

    @abstractmethod
    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        """Return the trajectory through the task's stops and a dict of details."""
