"""Which actions are allowed where: segment validity along each move, batched collision checks, and why not."""

from __future__ import annotations

import math

import numpy as np

from ..stations.validity import MotionValidity
from .action_sets import ActionSet


class ActionMasks:
    """The action masks (sb3-contrib convention: True where allowed) of an action set.

    An action is masked when the joint limits or an active joint restriction (thesis §4.1) are violated along its
    move (checked every ``resolution`` [rad]), or when the robot comes closer to an obstacle than the validity's
    collision margin (at least 2 mm) anywhere along it: collisions are checked continuously with the planners'
    :class:`~dresspack_gym.stations.validity.MotionValidity`, so every trajectory a masked policy drives is valid for
    the planners' checker too. The set's fallback actions are allowed only where every other move is masked."""

    def __init__(self, actions: ActionSet, validity: MotionValidity, restrictions, step: float, substeps: int):
        self.actions = actions
        self.validity = validity
        self.checker = validity.checker
        self.restrictions = restrictions
        self.step, self.substeps = float(step), int(substeps)  # a step of ``step`` [rad] is checked ``substeps`` times
        # the moves (every action but the wait), split once: masks_at runs on every step
        moves = actions.moves()
        self.first_moves, self.fallback_moves = moves[~actions.fallback[moves]], moves[actions.fallback[moves]]
        self._cache: tuple[bytes, np.ndarray] | None = None

    def current(self, q: np.ndarray, goal: np.ndarray, goal_index: int) -> np.ndarray:
        """``masks_at(q, goal)``, kept while the robot stands at ``q`` heading for goal ``goal_index``."""
        key = q.tobytes() + bytes([goal_index])
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, self.masks_at(q, goal))
        return self._cache[1].copy()

    def forget(self) -> None:
        """Drop the kept mask (the robot moved, or what an action offers changed)."""
        self._cache = None

    def kept(self) -> tuple[bytes, np.ndarray] | None:
        """The kept mask with the place it belongs to (for a snapshot), or None."""
        return self._cache

    def keep(self, kept: tuple[bytes, np.ndarray] | None) -> None:
        """Reinstate a mask from :meth:`kept`: a restored snapshot needs no new collision checks where it stands
        (a search steps many actions from one state), and the key still guards against a different place."""
        self._cache = kept

    def masks_at(self, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """The action mask at configuration ``q`` heading for ``goal``."""
        masks = np.ones(self.actions.n_actions, dtype=bool)
        first, rest = self.first_moves, self.fallback_moves
        masks[first] = self._moves_free(q, goal, first)
        masks[rest] = False if masks[first].any() else self._moves_free(q, goal, rest)
        return masks

    def _moves_free(self, q: np.ndarray, goal: np.ndarray, moves: np.ndarray) -> np.ndarray:
        """Which of ``moves`` from ``q`` pass the limits, restrictions and the continuous collision check."""
        if not len(moves):
            return np.zeros(0, dtype=bool)
        targets = np.array([self.actions.target(q, a, goal) for a in moves])
        free = self._segments_allowed(q, targets)
        free &= self.actions.offered(moves, goal)
        # Moves whose largest possible robot displacement stays below the clearance beyond the margin cannot
        # come closer than the margin anywhere: they skip the collision queries (a continuous guarantee that
        # implies MotionValidity.segment_valid, so planners accept every step a masked policy takes).
        clearance = self.checker.min_distance(q) - self.checker.margin
        reach = self.checker.chain_reach()
        # the moves that pass limits and restrictions and could come near an obstacle: their collision checks
        # advance together, each round's distance queries in one batch
        near = np.flatnonzero(free & (np.abs(targets - q) @ reach >= clearance))
        if len(near):
            free[near] = self.validity.segments_clear(q, targets[near])
        return free

    def segment_configs(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        """The configurations a straight segment is checked at (at least ``substeps``, one per resolution)."""
        n = max(self.substeps, int(math.ceil(np.max(np.abs(q1 - q0)) / (self.step / self.substeps))))
        s = np.linspace(0.0, 1.0, n + 1)[1:, None]
        return q0[None, :] + s * (q1 - q0)[None, :]

    def _segments_allowed(self, q0: np.ndarray, q1s: np.ndarray) -> np.ndarray:
        """``segment_valid(q0, q1, check_collision=False)`` of every row of ``q1s``: the segments' configurations
        checked in one batch (the per-segment calls cost more than the checks themselves)."""
        dq = q1s - q0
        checks = np.maximum(self.substeps, np.ceil(np.max(np.abs(dq), axis=1, initial=0.0)
                                                   / (self.step / self.substeps)).astype(int))
        allowed = np.zeros(len(q1s), dtype=bool)
        for n in np.unique(checks):  # segments checked as often share their fractions (joint steps: all of them)
            rows = np.flatnonzero(checks == n)
            s = np.linspace(0.0, 1.0, n + 1)[1:, None, None]
            qs = (q0[None, None, :] + s * dq[None, rows, :]).reshape(-1, q0.size)  # as segment_configs makes them
            ok = (self.validity.within_limits(qs) & self.restrictions.allowed(qs)).reshape(n, len(rows))
            allowed[rows] = ok.all(axis=0)
        return allowed

    def segment_valid(self, q0: np.ndarray, q1: np.ndarray, check_collision: bool = True) -> bool:
        """The straight segment q0 -> q1 stays within the limits and restrictions (and clear of obstacles)."""
        qs = self.segment_configs(q0, q1)
        if not (self.validity.within_limits(qs).all() and self.restrictions.allowed(qs).all()):
            return False
        return not check_collision or self.validity.segment_clear(q0, q1)

    def why_masked(self, q: np.ndarray, goal: np.ndarray, a: int) -> str:
        """Why action ``a`` is masked at ``q`` heading for ``goal``."""
        if self.actions.fallback[a] and self.masks_at(q, goal)[self.first_moves].any():  # another move is free
            return "a fallback via: offered only where no other move is free"
        why = self.actions.why_not_offered(a, goal)
        if why is not None:
            return why
        qs = self.segment_configs(q, self.actions.target(q, a, goal))
        if not self.validity.within_limits(qs).all():
            return "joint limit"
        bad = ~self.restrictions.allowed(qs)
        if bad.any():
            return "joint restriction: " + "; ".join(self.restrictions.violated_by(qs[np.argmax(bad)]))
        return "robot-obstacle collision"
