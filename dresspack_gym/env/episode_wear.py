"""An episode's wear bookkeeping: the wear cost integrated over each step, per-segment damage, fatigue life."""

from __future__ import annotations

import numpy as np

from ..cable.config import DresspackConfig
from ..physics.damage import damage_rate
from ..physics.fatigue import fatigue_life
from ..physics.segment_state import SegmentState

# the wear cost's terms, in the order a cost row holds them
COST_TERMS = ("total", "curvature", "tension", "distance", "twist", "damage")


def cost_row(cost) -> np.ndarray:
    """A WearCost as numbers in COST_TERMS order."""
    return np.array([cost.total, cost.curvature, cost.tension, cost.distance, cost.twist, cost.damage])


def trapezoid(times: list[float], rows: list[np.ndarray]) -> np.ndarray:
    """Per term of COST_TERMS, the integral over a step from its samples (start, on the way, end)."""
    t, c = np.asarray(times, dtype=float), np.asarray(rows, dtype=float)
    return np.sum(0.5 * (c[1:] + c[:-1]) * np.diff(t)[:, None], axis=0)


class EpisodeWear:
    """What the cable went through this episode: the cost terms where the next step's wear integral starts
    (``cost_now``), per segment the damage so far (value terms, trapezoid over the steps' end states; see
    physics/damage.py) and the segment states at step ends, which give the episode's fatigue life as one station
    cycle."""

    def __init__(self, dresspack: DresspackConfig):
        self.dresspack = dresspack

    def begin(self, state: SegmentState, cost) -> None:
        """A new episode starting in ``state`` with wear cost ``cost``."""
        self.cost_now = cost_row(cost)
        self.states = [state]
        self.rate = damage_rate(state, self.dresspack)
        self.damage = np.zeros_like(self.rate)

    def end_step(self, step_time: float, state: SegmentState, times: list[float], rows: list[np.ndarray],
                 cost) -> np.ndarray:
        """A step of ``step_time`` ended in ``state`` with wear cost ``cost``: ``times`` are the motion times from
        its start to its end, ``rows`` the cost terms sampled at all but the end (on the way with wear_integral).
        Returns the step's integral per COST_TERMS."""
        self.cost_now = cost_row(cost)
        integral = trapezoid(times, [*rows, self.cost_now])
        self.states.append(state)
        rate = damage_rate(state, self.dresspack)
        self.damage += 0.5 * (self.rate + rate) * step_time
        self.rate = rate
        return integral

    @property
    def max_damage(self) -> float:
        return float(self.damage.max())

    def life_cycles(self) -> float:
        """How many times the episode's cycle could repeat before the weakest segment fails (fatigue)."""
        dp = self.dresspack
        return fatigue_life(self.states, dp.fatigue, np.arange(dp.segments + 1) * dp.segment_length,
                            dp.tensile_stiffness).summary()["life_cycles"]

    def state(self) -> tuple:
        """Everything above, for a snapshot."""
        return self.cost_now.copy(), self.damage.copy(), self.rate.copy(), list(self.states)

    def set_state(self, state: tuple) -> None:
        cost_now, damage, rate, states = state
        self.cost_now, self.damage, self.rate, self.states = cost_now.copy(), damage.copy(), rate.copy(), list(states)
