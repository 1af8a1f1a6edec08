"""What every action set of the env provides: its size, its wait, where each action moves, and how it reads."""

from __future__ import annotations

import numpy as np


class ActionSet:
    """A discrete action set: action ``a`` taken at ``q`` heading for ``goal`` is one straight joint-space segment to
    ``target(q, a, goal)`` (the wait, ``stay_action``, stays). The env masks, moves, times and observes every action
    the same way; an action set only says where its actions go, which of them it offers at all, and what it adds to
    the observation.

    ``fallback[a]``: action ``a`` is offered only where no other move is free (a policy keeps to the others and uses
    these to get out of a spot they cannot leave)."""

    name = ""
    n_actions: int
    stay_action: int
    fallback: np.ndarray

    def target(self, q: np.ndarray, a: int, goal: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def describe(self, a: int) -> str:
        raise NotImplementedError

    def moves(self) -> np.ndarray:
        """Every action but the wait, in action order."""
        return np.array([a for a in range(self.n_actions) if a != self.stay_action])

    def offered(self, moves: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Per action of ``moves``, whether it exists toward ``goal`` (all do unless a set says otherwise)."""
        return np.ones(len(moves), dtype=bool)

    def why_not_offered(self, a: int, goal: np.ndarray) -> str | None:
        """Why action ``a`` does not exist toward ``goal``; None when it does."""
        return None

    def approaches(self, goal: np.ndarray) -> np.ndarray:
        """The approach configurations the set goes to toward ``goal``, (k, 6) (none unless a set has them)."""
        return np.zeros((0, 6))

    def observation_parts(self) -> dict[str, int]:
        """The parts this set adds to the observation (name -> size, in order), after the env's own."""
        return {}

    def observe(self, q: np.ndarray, goal: np.ndarray) -> dict[str, np.ndarray]:
        """The values of ``observation_parts`` but the action mask (which the env knows)."""
        return {}
