"""Joint steps: move one joint by a fixed step, wait, or (optionally) step all joints toward the goal."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .base import ActionSet

if TYPE_CHECKING:
    from ...stations.validity import MotionValidity

N_JOINT_ACTIONS = 12
STAY = 12
TOWARD_GOAL = 13


class JointSteps(ActionSet):
    """``Discrete(13)``, or ``Discrete(14)`` with ``goal_action``: action ``2 j`` moves joint ``j`` by ``+step``,
    ``2 j + 1`` by ``-step`` (j = 0..5), action 12 holds still for a step's worth of time, action 13 (optional) moves
    all joints together straight toward the goal, the largest joint change being ``step`` (a straight joint-space
    move is what a planner's segment is, so a policy can match a planner's cycle time where the straight way is
    free)."""

    name = "joint_steps"

    def __init__(self, step: float, goal_action: bool = False):
        self.step = float(step)  # [rad]
        self.goal_action = bool(goal_action)
        self.n_actions = N_JOINT_ACTIONS + (2 if self.goal_action else 1)
        self.stay_action = STAY
        self.fallback = np.zeros(self.n_actions, dtype=bool)

    @classmethod
    def from_config(cls, config, validity: MotionValidity, joint_limits: np.ndarray) -> JointSteps:
        """The set an envs ``EnvConfig`` asks for (passed in, not imported: the config checks its action set
        against this package)."""
        return cls(math.radians(config.joint_step_deg), config.goal_action)

    def target(self, q: np.ndarray, a: int, goal: np.ndarray) -> np.ndarray:
        if a == TOWARD_GOAL:
            err = goal - q
            return q + err * min(1.0, self.step / max(float(np.max(np.abs(err))), 1e-12))
        target = q.copy()
        if a != STAY:
            target[a // 2] += self.step if a % 2 == 0 else -self.step
        return target

    def describe(self, a: int) -> str:
        if a == STAY:
            return "stay"
        if a == TOWARD_GOAL:
            return f"toward goal (<= {math.degrees(self.step):g} deg)"
        return f"j{a // 2 + 1} {'+' if a % 2 == 0 else '-'}{math.degrees(self.step):g} deg"
