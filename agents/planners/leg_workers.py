"""Leg costs simulated on worker processes: a planner's candidate legs and refinement trials, several at a time."""

from __future__ import annotations

import multiprocessing.pool
import weakref

from dresspack_gym.cli.args import MAX_JOBS
from dresspack_gym.errors import ConfigError
from dresspack_gym.process_pool import spawn_pool


def check_jobs(jobs) -> int:
    """``jobs`` as an int, or a ConfigError naming the field and the allowed range."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or not 1 <= jobs <= MAX_JOBS:
        raise ConfigError("jobs", f"must be an integer in [1, {MAX_JOBS}] (processes simulating legs), got {jobs!r}")
    return jobs


class Pending:
    """A leg being simulated on a worker, with the bound it runs with."""

    def __init__(self, result: multiprocessing.pool.AsyncResult, bound: float):
        self._result, self.bound = result, bound

    def result(self):
        return self._result.get()


class LegWorkers:
    """``jobs`` processes, each with its own station and leg cost (``leg_cost(Station(config), **settings)``), that
    simulate legs from given cable states. A leg's simulation is a function of its start state alone (the
    simulators' whole state is in it), so a worker's answer is the one the planner's own simulator would give."""

    def __init__(self, leg_cost: type, config, settings: dict, jobs: int):
        self._pool = spawn_pool(jobs, _init, (leg_cost, config, settings))
        self._closed = weakref.finalize(self, self._pool.terminate)
        for _ in range(jobs):  # each worker builds its station while the planner searches its first routes
            self._pool.apply_async(_warm)

    def submit(self, start_state, waypoints, bound: float) -> Pending:
        return Pending(self._pool.apply_async(_simulate, (start_state, waypoints, bound)), bound)

    def close(self) -> None:
        self._closed()


_WORKER: dict = {}  # a worker's arguments, then its LegCost (built by its first task)


def _init(leg_cost: type, config, settings: dict) -> None:
    """Nothing that can fail runs here: a failing initializer makes the pool start workers forever."""
    _WORKER["args"] = (leg_cost, config, settings)


def _leg_cost():
    if "cost" not in _WORKER:
        from dresspack_gym.stations.station import Station

        leg_cost, config, settings = _WORKER["args"]
        _WORKER["cost"] = leg_cost(Station(config), **settings)
    return _WORKER["cost"]


def _warm() -> None:
    _leg_cost()


def _simulate(start_state, waypoints, bound: float):
    return _leg_cost().simulate(start_state, waypoints, bound, track=True)
