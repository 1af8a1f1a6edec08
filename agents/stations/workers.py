"""The station planner's worker processes: weld options' cable settles, straight-move checks, leg plans and leg runs,
and CP-SAT solves that do not wait for each other (bounds, the two interlock models of a round)."""

from __future__ import annotations

from dresspack_gym.process_pool import spawn_pool

# Items per work unit sent to a worker: enough to amortise a round trip, few enough to keep both cores busy to the end
CHUNK = 4

_PLANNER = None  # a worker's own StationPlanner (one process, no pool), built once by _init_worker


class StationWorkers:
    """``jobs`` processes, each with its own planner of the station (the same settings, one process), that
    compute what only depends on its inputs: a settled option's cost rate, a straight move's validity, a leg's
    path, and a leg's timed motion and cable run. Every result is the one the parent would compute itself, so the
    plan does not depend on ``jobs``. With ``jobs`` 1 nothing is started: the caller computes in its own process.
    The pool starts with the first work and lives until :meth:`close`."""

    def __init__(self, planner_class: type, station_config, config, jobs: int):
        self.settings = (planner_class, station_config, config)
        self.jobs = int(jobs)
        self._pool = None

    @property
    def parallel(self) -> bool:
        return self.jobs > 1

    def map(self, task: str, items: list, bar=None) -> list:
        """``task`` (a name in :data:`_TASKS`) on every item, in processes; the results in the items' order
        (``bar``: a progress bar, updated as they come)."""
        if not items:
            return []
        pool = self._started()
        units = [items[s:s + CHUNK] for s in range(0, len(items), CHUNK)]
        out = []
        for part in pool.imap(_run_unit, [(task, u) for u in units]):
            out += part
            if bar is not None:
                bar.update(len(part))
        return out

    def submit(self, task: str, item) -> Pending:
        """``task`` on ``item`` started in a worker now (with one job: computed here when asked for); its result
        is :meth:`Pending.get`'s."""
        if not self.parallel:
            return Pending(lambda: _TASKS[task](item))
        result = self._started().apply_async(_run_unit, ((task, [item]),))
        return Pending(lambda: result.get()[0])

    def _started(self):
        if self._pool is None:
            # each worker builds its own MuJoCo models, OMPL planners and rod engine from nothing the parent holds
            self._pool = spawn_pool(self.jobs, _init_worker, self.settings)
        return self._pool

    def close(self) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None


class Pending:
    """A result on its way: :meth:`get` waits for it (once; later calls return it again)."""

    def __init__(self, compute):
        self._compute, self._done, self._value = compute, False, None

    def get(self):
        if not self._done:
            self._value, self._done = self._compute(), True
        return self._value


def _init_worker(planner_class: type, station_config, config) -> None:
    """A worker's planner of the station, of the parent's planner class."""
    global _PLANNER
    from dataclasses import replace

    from dresspack_gym.stations.station import Station

    _PLANNER = planner_class(Station(station_config), replace(config, jobs=1))


def _settle(item):
    robot, q = item
    rate = _PLANNER.costs.rate(robot, q)
    return rate, _PLANNER.costs.converged(robot, q)


def _straight(item):
    robot, qa, qb = item
    return bool(_PLANNER.legs.planners[robot].validity.segment_valid(qa, qb))


def _leg(item):
    from .legs_up_front import plan_leg

    robot, qa, qb = item
    return plan_leg(_PLANNER.legs.planners[robot], robot, qa, qb)


def _run(item):
    robot, leg, weld_time = item
    legs = _PLANNER.legs
    return legs.motion(robot, leg).fly_by, legs.run(robot, leg, weld_time)


def _solve(item):
    from .solver import solve

    problem, objective, kwargs = item
    return solve(problem, objective, **kwargs)


def _makespan_bound(item):
    from .solver import relaxation_bound

    problem, work, seed = item
    return relaxation_bound(problem, work=work, seed=seed)


def _wear_bound(item):
    from .solver import wear_relaxation_bound

    problem, cap, work, seed = item
    return wear_relaxation_bound(problem, cap, work=work, seed=seed)


_TASKS = {"settle": _settle, "straight": _straight, "leg": _leg, "run": _run, "solve": _solve,
          "makespan_bound": _makespan_bound, "wear_bound": _wear_bound}


def _run_unit(unit):
    task, items = unit
    return [_TASKS[task](item) for item in items]
