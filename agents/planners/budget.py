"""Planning budgets in work units, so a plan's result does not depend on machine speed or load."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from dresspack_gym.errors import ConfigError

DEFAULT_ITERATIONS = 3000
DEFAULT_ROUTES = 12
DEFAULT_EVALUATIONS = 40
MAX_WORK = 10**7  # iterations / routes / evaluations per plan: beyond this a plan runs for days
MAX_WALL_TIME = 86_400.0  # [s] a day


@dataclass(frozen=True)
class Budget:
    """How much work one plan may do.

    ``iterations``: OMPL planner iterations per connection of two configurations (RRTConnect loop passes).
    ``routes``: candidate routes per leg that a route-exploring planner samples and scores (one cable
    simulation each).
    ``evaluations``: cable-leg cost queries of the local refinement, per plan (wear-aware planners).
    ``wall_time``: optional cap [s] on the whole plan. Work units make a plan reproducible on any machine; a plan
    stopped by the wall cap is not (it depends on load), so the cap is off unless asked for.
    """

    iterations: int = DEFAULT_ITERATIONS
    evaluations: int = DEFAULT_EVALUATIONS
    routes: int = DEFAULT_ROUTES
    wall_time: float | None = None

    def __post_init__(self):
        for name in ("iterations", "evaluations", "routes"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_WORK:
                raise ConfigError(name, f"must be an integer in [1, {MAX_WORK}] (work units), got {value!r}")
        if self.wall_time is not None and not (isinstance(self.wall_time, (int, float))
                                               and 0 < self.wall_time <= MAX_WALL_TIME):
            raise ConfigError("time_budget", f"the wall-time cap must be a number of seconds in (0, {MAX_WALL_TIME:g}] "
                                             f"or None, got {self.wall_time!r}")


class Allowance:
    """The wall clock of one plan: ``out_of_time()`` once the cap (if any) is used up."""

    def __init__(self, budget: Budget):
        self.budget = budget
        self.start = time.perf_counter()
        self.deadline = math.inf if budget.wall_time is None else self.start + budget.wall_time

    def out_of_time(self) -> bool:
        return time.perf_counter() > self.deadline

    def elapsed(self) -> float:
        return time.perf_counter() - self.start
