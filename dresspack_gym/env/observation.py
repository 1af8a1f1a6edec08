"""The env's observation: its parts, their layout (``observation_structure``) and their values."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np

from .action_sets import ActionSet

# Observations are clipped to +-OBS_BOUND (all parts are scaled to about [-1, 1]); clearance is observed as d/c up
# to CLEARANCE_OBS_CAP: farther than a few clearance thresholds from everything carries no information.
OBS_BOUND = 10.0
CLEARANCE_OBS_CAP = 5.0
# [m] the goal tool position is observed relative to the robot's base in these units (the shipped robots reach
# 2.55-2.7 m), so it stays within about [-1, 1]
POSE_SCALE = 3.0


class Observation:
    """float32, all parts roughly in [-1, 1], laid out by ``structure`` (part name -> size, in order; the space's
    size is their sum): joints scaled by their limits (6), goal scaled likewise (6), joint error to the goal / pi
    (6), task progress (1), ``cable_samples`` cable points in the TCP frame divided by the cable length (3 each), and
    the measures κ/κ0, F/``tension_scale``, d/c (3); with ``goal_pose`` (goals drawn every episode) also the goal's
    tool position from the base / ``POSE_SCALE`` and its approach direction (6); then the action set's parts (the
    primitives': each approach configuration's joint change from where the robot is / pi, 6 each, zeros for an
    approach the goal does not have; the action mask, +1 allowed, -1 masked, one per action)."""

    def __init__(self, sim, robot_index: int, actions: ActionSet, cable_samples: int,
                 goal_pose: bool):
        self.sim, self.robot_index, self.actions = sim, robot_index, actions
        self.placement = sim.station.config.robots[robot_index]
        self.kinematics = sim.station.robots[robot_index].kinematics
        self.limits = self.placement.robot.joint_limits
        self.wear_config = sim.station.config.wear_cost
        self.cable_samples = int(cable_samples)
        self.structure = {"joints": 6, "goal": 6, "goal_error": 6, "progress": 1,
                          "cable_points": 3 * self.cable_samples, "measures": 3}
        if goal_pose:  # goals change every episode: the goal's tool pose too (position, approach)
            self.structure["goal_pose"] = 6
        self.structure.update(actions.observation_parts())
        self.space = gym.spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(sum(self.structure.values()),), dtype=np.float32)

    def build(self, goal: np.ndarray, progress: float, measures, masks: Callable[[], np.ndarray]) -> np.ndarray:
        """The observation of the robot where it is, heading for ``goal``; ``masks()`` gives the action mask."""
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        scale = lambda v: 2.0 * (v - lo) / (hi - lo) - 1.0  # noqa: E731
        q = self.sim.q[self.robot_index].copy()
        pts = self.sim.cable_points(self.robot_index)
        idx = np.linspace(0, len(pts) - 1, self.cable_samples).round().astype(int)
        tcp = self.kinematics.tcp_pose(q)
        cfg = self.wear_config
        parts = {
            "joints": scale(q),
            "goal": scale(goal),
            "goal_error": (q - goal) / np.pi,
            "progress": [progress],
            "cable_points": ((pts[idx] - tcp[:3, 3]) @ tcp[:3, :3] / self.placement.dresspack.length).ravel(),
            "measures": [measures.max_curvature / max(cfg.curvature_threshold, 1e-6),
                         measures.max_tension / cfg.tension_scale,
                         min(measures.min_clearance / max(cfg.clearance, 1e-6), CLEARANCE_OBS_CAP)],
        }
        if "goal_pose" in self.structure:
            goal_tcp = self.kinematics.tcp_pose(goal)
            base = np.asarray(self.placement.base_pos)
            parts["goal_pose"] = np.concatenate([(goal_tcp[:3, 3] - base) / POSE_SCALE, goal_tcp[:3, 2]])
        parts.update(self.actions.observe(q, goal))
        if "action_masks" in self.structure:
            parts["action_masks"] = np.where(masks(), 1.0, -1.0)
        obs = np.concatenate([parts[k] for k in self.structure])
        return np.clip(obs, -OBS_BOUND, OBS_BOUND).astype(np.float32)
