"""Coordinating a station plan's robots: candidate routes with their planned legs, timed and ordered by waits
(dresspack_gym.multi.coordination), and the best candidate chosen for the objective."""

from __future__ import annotations

import numpy as np

from dresspack_gym.multi.coordination import RobotPairDistance, coordinate
from dresspack_gym.multi.schedule import RobotSchedule, StationSchedule
from dresspack_gym.multi.tasks import StationTask, WeldOption
from dresspack_gym.stations.station import Station

from ..planners.base import PlanningError
from .config import EXTRA_ROUNDS, StationPlanConfig
from .legs import LegBook
from .problem import BLOCKED
from .solver import SPAN_WEIGHT, Assignment, RoutingProblem


def routes_key(routes) -> tuple:
    return tuple(map(tuple, routes))


class Coordinator:
    """Coordinates candidate routes of one station; a resolved coordination is cached by the routes and their legs
    (it depends on nothing else), shared by every plan of the station."""

    def __init__(self, station: Station):
        self.station = station
        self._coordinations: dict[tuple, tuple] = {}

    def schedule(self, task: StationTask, options: list[WeldOption], routes, qs: np.ndarray,
                 legs: LegBook) -> StationSchedule:
        """``routes`` with their planned legs, every robot as soon as possible (no waits yet)."""
        R = task.n_robots
        schedules = []
        for r, route in enumerate(routes):
            if not route:  # a robot without welds stays Home (and is still an obstacle to the others)
                schedules.append(RobotSchedule.as_soon_as_possible(r, [], [np.array([task.homes[r]] * 2)],
                                                                   legs.limits[r], task.weld_time))
                continue
            path = [r, *route, r]
            paths = [legs.leg(r, a, b, qs) for a, b in zip(path[:-1], path[1:])]
            schedules.append(RobotSchedule.as_soon_as_possible(r, [options[n - R].weld for n in route], paths,
                                                               legs.limits[r], task.weld_time,
                                                               motions=[legs.motion(r, g) for g in paths]))
        return StationSchedule(tuple(schedules), task.homes)

    def coordinated(self, problem: RoutingProblem, routes, task: StationTask, options: list[WeldOption],
                    qs: np.ndarray, pairs: RobotPairDistance, legs: LegBook, cap: float = np.inf):
        """``routes`` with their planned legs, coordinated: (schedule, coordination info, wear with the waits: at
        the waiting robot's stop, and the cables hanging at Home until the coordinated makespan), or None when no
        robot order ends before ``cap``. A resolved one is cached by the routes and their legs (the best order
        below one cap is the best below any cap above it)."""
        paths = tuple(None if (g := legs.leg(r, a, b, qs)) is None else g.tobytes()
                      for r, route in enumerate(routes) for a, b in zip([r, *route], [*route, r]))
        key = (routes_key(routes), paths, qs.tobytes())
        if key in self._coordinations:
            schedule, info = self._coordinations[key]
            if schedule.makespan >= cap:
                return None
            info = dict(info)
        else:
            schedule, info = coordinate(self.station, self.schedule(task, options, routes, qs, legs), pairs, cap=cap)
            if schedule is None:
                return None
            if info["resolved"]:  # an unresolved one may depend on the cap (orders given up at it)
                self._coordinations[key] = (schedule, dict(info))
        estimate = problem.evaluate(routes)
        stops = {r: [r, *route] for r, route in enumerate(routes)}
        wait_wear = sum(w * problem.cost_rate[stops[s.robot][k]] for s in schedule.robots
                        for k, w in enumerate(s.waits()))
        ends = {s.robot: s.end_time for s in schedule.robots}
        idle = problem.idle_wear([ends[r] for r in range(len(routes))], schedule.makespan)
        return schedule, info, estimate["wear"] - estimate["idle_wear"] + float(wait_wear) + idle

    def best(self, problem: RoutingProblem, candidates: list[Assignment], task: StationTask,
             options: list[WeldOption], qs: np.ndarray, pairs: RobotPairDistance, legs: LegBook,
             config: StationPlanConfig, bar, reference: float | None = None):
        """The best of the solved assignments once their legs are planned and their robots coordinated: the
        solver saw straight-move times (lower bounds of planned legs) and only a guess of the waits, so a later
        round's answer, or the wear objective's, can turn out the worse one. Wear counts the waits at the
        waiting robot's stop and the cables hanging at Home until the coordinated makespan. The wear objective
        keeps within its slack of ``reference`` (the time plan's makespan: the plan it is compared with), or of
        its fastest candidate without one. Returns (assignment, coordinated schedule, coordination info)."""
        cfg = config
        unique = list({tuple(map(tuple, a.routes)): a for a in candidates}.values())
        exact = [Assignment(a.routes, {**a.estimate, **problem.evaluate(a.routes)}, a.objective) for a in unique]
        exact = [a for a in exact if a.estimate["makespan"] < BLOCKED]
        if not exact:
            names = [r.name for r in self.station.config.robots]
            raise _blocked_error(problem, unique, task, options, cfg, names)
        scored = []
        bar = bar("coordinating the candidate plans", len(exact))
        # the time objective wants the fastest coordinated candidate only: candidates in order of their makespan
        # without waits, each coordinated only as far as it can still beat the best so far (waits only add), and
        # skipped once even its makespan without waits cannot. The same answer as coordinating all of them
        fastest_only = cfg.objective == "time"
        if fastest_only:
            exact.sort(key=lambda a: a.estimate["makespan"])
        beat = np.inf
        for a in exact:
            bar.update(1)
            if a.estimate["makespan"] >= beat:
                continue
            got = self.coordinated(problem, a.routes, task, options, qs, pairs, legs, cap=beat)
            if got is None:  # every order ended no sooner than the best so far
                continue
            schedule, info, wear = got
            if fastest_only and info["resolved"]:
                beat = min(beat, schedule.makespan)
            a.estimate.update(coordinated_makespan=schedule.makespan, waits=schedule.total_wait(),
                              wear_with_waits=wear, resolved=info["resolved"])
            scored.append((a, schedule, info))
        bar.close()
        ok = [x for x in scored if x[2]["resolved"]] or scored
        fastest = min(ok, key=lambda x: (x[1].makespan, x[0].estimate["time"]))
        # the wear objective's cap is measured from the time plan, as its comparison is: measured from its own
        # fastest candidate, a candidate of its rounds faster than the time plan (27.5 against 29.4 s on
        # side_framing_4r) shrank its room to nothing
        reference = fastest[1].makespan if reference is None else float(reference)
        cap = reference * (1 + cfg.makespan_slack)
        for x in scored:
            x[2].update(fastest_candidate_makespan=fastest[1].makespan, makespan_reference=reference,
                        makespan_cap=cap)
        if cfg.objective == "time":
            return fastest
        if cfg.objective == "wear":
            within = [x for x in ok if x[1].makespan <= cap + 1e-9] or [fastest]
            return min(within, key=lambda x: x[0].estimate["wear_with_waits"])
        weight = fastest[0].estimate["time"] / max(fastest[0].estimate["wear_with_waits"], 1e-9)
        return min(ok, key=lambda x: SPAN_WEIGHT * x[1].makespan + x[0].estimate["time"]
                   + weight * x[0].estimate["wear_with_waits"])


def _blocked_error(problem: RoutingProblem, answers: list[Assignment], task: StationTask,
                   options: list[WeldOption], cfg: StationPlanConfig, names: list[str]) -> PlanningError:
    """The error of a station whose every answer has a leg no path was found for: it names the robots (the field
    of the station file to look at) and their blocked moves."""
    stops = ["Home"] * task.n_robots + [o.weld for o in options]
    blocked: dict[int, list[str]] = {}
    for a in answers:
        for r, route in enumerate(a.routes):
            for i, j in zip([r, *route], [*route, r]):
                move = f"{stops[i]} -> {stops[j]}"
                if problem.travel[r, i, j] >= BLOCKED and move not in blocked.get(r, []):
                    blocked.setdefault(r, []).append(move)
    return PlanningError(
        f"no assignment found whose every leg could be planned within {cfg.iterations} iterations in "
        f"{EXTRA_ROUNDS * cfg.exact_rounds} rounds; no collision-free path for "
        + "; ".join(f"{names[r]} {', '.join(moves)}" for r, moves in sorted(blocked.items()))
        + " (raise --iterations, or move the robot or the welds it must reach)",
        field="robots." + ",".join(names[r] for r in sorted(blocked)))
