"""Validity of robot configurations and straight joint-space motions: limits, joint restrictions, collisions."""

from __future__ import annotations

import math

import numpy as np

from .collision import RobotCollisionChecker
from .joint_limits import within_limits
from .station import Station


MIN_MARGIN = 0.002  # [m] conservative advancement needs a positive clearance to make progress
# [m] robot-station clearance the planners keep (and the policy's masks, so its paths pass the planners' check)
PLANNER_MARGIN = 0.005


class MotionValidity:
    """``valid(q)`` and ``segment_valid(q0, q1)`` for one robot; segments are checked every ``resolution``.

    Cheap checks first (limits, the thesis joint restrictions), then MuJoCo distance queries. A segment is
    collision-free in the continuous sense (not only at samples) with clearance >= margin / 2.
    """

    def __init__(self, station: Station, robot: int = 0, margin: float = 0.0, resolution_deg: float = 2.0):
        robot = station.check_robot(robot)
        placement = station.config.robots[robot]
        self.limits = placement.robot.joint_limits
        self.restrictions = placement.restrictions
        self.checker = RobotCollisionChecker(station, robot, max(margin, MIN_MARGIN))
        self.resolution = math.radians(resolution_deg)
        self.n_checks = 0  # collision queries made (planning cost accounting)

    def within_limits(self, q: np.ndarray) -> np.ndarray:
        return within_limits(q, self.limits)

    def valid(self, q) -> bool:
        q = np.asarray(q, dtype=float)
        if not (self.within_limits(q)[0] and self.restrictions.allowed(q)[0]):
            return False
        self.n_checks += 1
        return not self.checker.collides(q)  # early exit: cheaper than the full distance

    def why_invalid(self, q) -> str:
        q = np.asarray(q, dtype=float)
        if not self.within_limits(q)[0]:
            return "outside the joint limits"
        broken = self.restrictions.violated_by(q)
        if broken:
            return "joint restriction: " + "; ".join(broken)
        return "collides with the station" if self.checker.collides(q) else ""

    def segment_valid(self, q0, q1) -> bool:
        """Joint limits and restrictions sampled every ``resolution`` (they are cheap, smooth functions of q);
        collisions checked continuously by conservative advancement: from a configuration with clearance d,
        no robot point moves farther than ``chain_reach @ |dq|``, so the next check can be that far along."""
        q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
        n = max(1, int(math.ceil(np.max(np.abs(q1 - q0)) / self.resolution)))
        qs = q0 + np.linspace(0.0, 1.0, n + 1)[1:, None] * (q1 - q0)
        if not (self.within_limits(qs).all() and self.restrictions.allowed(qs).all()):
            return False
        return self.segment_clear(q0, q1)

    def segment_clear(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        """The collision part of :meth:`segment_valid` alone (for callers that checked limits/restrictions)."""
        reach_per_t = float(self.checker.chain_reach() @ np.abs(q1 - q0))
        margin = self.checker.margin
        t = 0.0
        while True:
            self.n_checks += 1
            d = self.checker.min_distance(q0 + t * (q1 - q0))
            if d < margin:
                return False
            if t >= 1.0 or reach_per_t == 0.0:
                return True
            t = min(1.0, t + (d - 0.5 * margin) / reach_per_t)  # clearance stays above margin / 2

    def path_valid(self, path) -> bool:
        path = np.asarray(path, dtype=float)
        return self.valid(path[0]) and all(self.segment_valid(a, b) for a, b in zip(path[:-1], path[1:]))
