"""Planner-like primitives: straight to the goal, or via a configuration (offset via, travel posture, approach)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ...robots.joint_limits import check_within_limits
from ...stations.approach import approach_configurations
from .base import ActionSet

if TYPE_CHECKING:
    from ...stations.validity import MotionValidity

# where a via configuration is taken from, as the fraction of the way toward the goal
VIA_ANCHORS = {"midpoint": 0.5, "here": 0.0}
TO_GOAL = 0
APPROACH_CACHE = 16  # goals whose approach configurations are kept (a search revisits an episode's few goals)


class Primitives(ActionSet):
    """Every action is one straight, rest-to-rest segment timed by the time law, so a replayed episode is a via path
    as smooth as a planner's, and an episode takes a few decisions per leg. ``Discrete(2 + 12 k a + p + v)`` for k
    ``offsets`` [rad], a ``anchors``, p ``postures`` and v approach vias, in action order:

    - 0 goes straight to the goal;
    - ``1 + 12 (k b + i) + 2 j (+1)`` goes to anchor ``b``'s configuration with joint ``j`` offset by
      ``+(-)offsets[i]`` (around an obstacle with j1-j3, re-orienting the wrist with j4-j6). Anchors: ``"midpoint"``
      (halfway toward the goal) and ``"here"`` (the current configuration: backing out of a tight spot, e.g. away
      from the panel just welded, before heading anywhere). An anchor in ``fallback_anchors`` offers its vias only
      where no other move is free;
    - then one action per travel posture: go to that configuration (a cell's travel positions, where the cable
      hangs easy; a wear-aware planner's routes pass through such postures, see ``scripts/studies/travel_postures.py``);
    - then ``approach_vias`` actions: via approach configuration k of the current goal (:mod:`approach`: free
      configurations within ``approach_reach`` of the goal from which the straight segment into it is free, drawn
      from the goal itself, so they are the same in any run); a weld in a pocket of the body admits only a narrow
      cone of straight entries, which no offset of the midpoint finds. A goal with fewer approaches than slots
      does not offer the rest;
    - the last action waits.
    """

    name = "primitives"

    def __init__(self, validity: MotionValidity, offsets: tuple[float, ...], anchors: tuple[str, ...],
                 fallback_anchors: tuple[str, ...] = (), postures: np.ndarray | None = None, approach_vias: int = 0,
                 approach_reach: float = 0.0):
        self.validity = validity
        # (fraction toward the goal, joint, signed offset) per via action, in action order 1..n
        self.vias = [(VIA_ANCHORS[anchor], j, sign * off) for anchor in anchors
                     for off in offsets for j in range(6) for sign in (1.0, -1.0)]
        self.postures = np.zeros((0, 6)) if postures is None else np.asarray(postures, dtype=float).reshape(-1, 6)
        self.approach_count, self.approach_reach = int(approach_vias), float(approach_reach)
        self.first_approach = 1 + len(self.vias) + len(self.postures)
        self.n_actions = 2 + len(self.vias) + len(self.postures) + self.approach_count
        self.stay_action = self.n_actions - 1
        self.fallback = np.array([False] + [anchor in fallback_anchors for anchor in anchors
                                            for _ in range(12 * len(offsets))]
                                 + [False] * (len(self.postures) + self.approach_count) + [False])
        self._approach_cache: dict[bytes, np.ndarray] = {}  # goal -> its approach configurations

    @classmethod
    def from_config(cls, config, validity: MotionValidity, joint_limits: np.ndarray) -> Primitives:
        """The set an envs ``EnvConfig`` asks for (passed in, not imported: the config checks its action set
        against this package)."""
        postures = np.radians(np.array(config.via_postures_deg, dtype=float).reshape(-1, 6))
        for k, posture in enumerate(postures):
            check_within_limits(posture, joint_limits, f"via_postures_deg[{k}]")
        return cls(validity, tuple(math.radians(off) for off in config.via_offsets_deg), config.via_anchors,
                   config.fallback_anchors, postures, config.approach_vias, math.radians(config.approach_range_deg))

    def target(self, q: np.ndarray, a: int, goal: np.ndarray) -> np.ndarray:
        if a == self.stay_action:
            return q.copy()
        if a == TO_GOAL:
            return goal.copy()
        if a >= self.first_approach:  # an approach configuration of the goal (none: no move, and not offered)
            found = self.approaches(goal)
            k = a - self.first_approach
            return found[k].copy() if k < len(found) else q.copy()
        if a > len(self.vias):  # a travel posture: where it is, wherever the robot and the goal are
            return self.postures[a - 1 - len(self.vias)].copy()
        fraction, j, offset = self.vias[a - 1]
        target = q + fraction * (goal - q)
        target[j] += offset
        return target

    def describe(self, a: int) -> str:
        if a == self.stay_action:
            return "stay"
        if a == TO_GOAL:
            return "straight to the goal"
        if a >= self.first_approach:
            return f"via approach configuration {a - self.first_approach} of the goal"
        if a > len(self.vias):
            return f"via travel posture {a - 1 - len(self.vias)}"
        fraction, j, offset = self.vias[a - 1]
        anchor = "the midpoint" if fraction else "here"
        return f"via {anchor} with j{j + 1} {math.degrees(offset):+g} deg"

    def offered(self, moves: np.ndarray, goal: np.ndarray) -> np.ndarray:
        if not self.approach_count:
            return np.ones(len(moves), dtype=bool)
        return moves < self.first_approach + len(self.approaches(goal))  # (the wait is not a move)

    def why_not_offered(self, a: int, goal: np.ndarray) -> str | None:
        if self.approach_count and self.first_approach <= a < self.stay_action \
                and a - self.first_approach >= len(self.approaches(goal)):
            return f"the goal has {len(self.approaches(goal))} approach configuration(s) within approach_range_deg"
        return None

    def approaches(self, goal: np.ndarray) -> np.ndarray:
        """The approach configurations of ``goal``, (k, 6) with k <= approach_vias."""
        goal = np.asarray(goal, dtype=float)
        key = goal.tobytes()
        found = self._approach_cache.pop(key, None)  # reinserted below: the least recently used goes first
        if found is None:
            if len(self._approach_cache) >= APPROACH_CACHE:  # goals change every episode (Home stays)
                self._approach_cache.pop(next(iter(self._approach_cache)))
            found = approach_configurations(self.validity, goal, self.approach_count, self.approach_reach)
        self._approach_cache[key] = found
        return found

    def observation_parts(self) -> dict[str, int]:
        # where the goal's approach configurations are, from here; which segments are free: probes of the geometry
        # along each candidate, so a changed station changes what the policy observes
        parts = {"approaches": 6 * self.approach_count} if self.approach_count else {}
        return {**parts, "action_masks": self.n_actions}

    def observe(self, q: np.ndarray, goal: np.ndarray) -> dict[str, np.ndarray]:
        if not self.approach_count:
            return {}
        rows = np.zeros((self.approach_count, 6))
        found = self.approaches(goal)
        rows[:len(found)] = (found - q) / np.pi
        return {"approaches": rows.ravel()}
