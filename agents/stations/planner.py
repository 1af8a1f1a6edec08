"""Planning a whole station: assign and order the welds over the robots, plan each chosen leg, coordinate the
robots by waits, verify, and run the result in the cable simulator.

Cheap estimates first, exact work on what is chosen: weld options are costed by their settled cable (one settle
per option, cached: option_costs.py), travel by the time law of the straight move and its wear at the mean of its
ends' settled rates (problem.py); the solver's chosen legs are then planned (collision-free) and run with their
robot's cable (from settled at the leg's start, through the motion and the weld after it; cached: legs.py); their
real durations and integrated wear replace the estimates, and the solver runs again until every chosen leg is exact
(rounds.py). A leg whose motion jams its robot's cable (drags it around the car body or its own links beyond the
jam strain) is re-routed or given up there (jams.py). The plan is then run in the cable simulator with every robot
on one clock (replay.py); a leg behind a jam found there is re-routed in the same way and the station planned again
(``cable_repairs`` times at most): a collision-free route is not yet a route the dresspack survives."""

from __future__ import annotations

import copy
from dataclasses import replace
from pathlib import Path

import numpy as np

from dresspack_gym.multi.replay import StationReplay
from dresspack_gym.multi.tasks import StationTask, WeldOption, make_station_task
from dresspack_gym.stations.station import Station

from .bounds import Bounds
from .config import LEG_PLANNERS, RECORD_EVERY, StationPlanConfig, no_bar
from .coordination import Coordinator
from .jams import jammed_legs, reroute
from .legs import LegBook
from .option_costs import OptionCosts
from .plan import StationPlan
from .problem import ProblemBuilder
from .replay import replay_plan
from .rounds import solve_rounds
from .solver import Assignment, RoutingProblem
from .workers import StationWorkers


class StationPlanner:
    """Plans a station's welds over its robots (see the module docstring) by composing its jobs: ``costs``
    (option costing), ``legs`` (leg planning), ``problems`` (the routing problem), ``bounds``, ``coordinator``;
    ``progress(label, total)`` may give a tqdm-like bar factory."""

    def __init__(self, station: Station, config: StationPlanConfig = StationPlanConfig(), progress=None):
        self.station = station
        self.config = config
        self.progress = progress
        self.names = [r.name for r in station.config.robots]
        leg_planners = [LEG_PLANNERS[config.leg_route](station, r, iterations=config.iterations, seed=config.seed)
                        for r in range(station.n_robots)]
        cfg = station.config
        limits = [r.robot.joint_motion_limits.at_speed(cfg.simulation.speed_fraction) for r in cfg.robots]
        # processes for what depends only on its inputs (settles, straight moves, legs, leg runs): shared by every
        # planner reconfigured from this one, ended by close()
        self.workers = StationWorkers(type(self), station.config, config, config.jobs)
        self.costs = OptionCosts(station, config.cost_variant, config.physics, self.workers)
        settings = (station.config, LEG_PLANNERS[config.leg_route], config.iterations, config.seed)
        self.legs = LegBook(leg_planners, limits, config.fly_by, self.costs, settings, self.workers)
        self.problems = ProblemBuilder(station)
        self.bounds = Bounds(self.workers)
        self.coordinator = Coordinator(station)
        # finished time plans by (config, task): the wear and balanced objectives take the time objective's
        # answer as a candidate, and the command has usually just planned it with the same settings (a plan
        # depends only on these, so the answer and the legs it asked for are reused, not planned again)
        self._time_answers: dict[tuple, tuple] = {}
        self.candidates: list[Assignment] = []  # the last rounds' candidates (a cable repair keeps them)

    def reconfigured(self, config: StationPlanConfig) -> StationPlanner:
        """A planner with ``config`` that keeps this one's settled-cable costs and planned legs (same station,
        seed, OMPL iterations, leg route and cost variant: the cached answers do not depend on anything else)."""
        shared = ("seed", "iterations", "cost_variant", "leg_route", "fly_by", "physics", "jobs")
        if any(getattr(config, f) != getattr(self.config, f) for f in shared):
            self.close()
            return StationPlanner(self.station, config, self.progress)
        other = copy.copy(self)  # shares the caches
        other.config = config
        other.legs = self.legs.fresh()
        return other

    def close(self) -> None:
        """End the worker processes (a later plan starts them again)."""
        self.workers.close()

    def __enter__(self) -> StationPlanner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def problem(self, task: StationTask, options: list[WeldOption]) -> RoutingProblem:
        """The routing problem over ``options`` with the legs this plan knows."""
        return self.problems.build(task, options, self.legs, self.costs, self.config.blocked_estimate)

    def plan(self, task: StationTask | None = None, cache: Path | None = None,
             leg_cache: Path | None = None) -> StationPlan:
        """Plan the station; with ``cable_repairs`` > 0 the plan is replayed with its cables (``plan.replay``), a
        leg that jammed a cable is re-routed (jams.REROUTES, then blocked) and the station planned again. The
        answer is the first plan without a jam, else the one with the fewest jammed cables (flagged in its
        replay); ``info["rerouted_legs"]`` lists what was changed (legs that jammed their cable alone are
        re-routed while planning, with or without repairs). ``cache``: the option costs' file; ``leg_cache``: the
        file the legs planned up front go to (``legs_up_front``), read back by a later run."""
        cfg, legs = self.config, self.legs
        if task is None:
            task = make_station_task(self.station, lambda r: legs.planners[r].validity.checker.collides,
                                     list(cfg.welds) if cfg.welds is not None else None, weld_time=cfg.weld_time,
                                     fixed_assignment=cfg.fixed_assignment)
        if cache is not None:
            self.costs.load(cache)
        options = self.costs.choose(task, cfg.costed_options, cfg.kept_options, self.bar)
        if cache is not None:
            self.costs.save(cache)
        legs.check_straight_moves(task, options, self.bar)
        if cfg.legs_up_front and cfg.objective != "time":
            legs.plan_every_move(task, options, leg_cache, workers=cfg.jobs, bar=self.bar)
        qs = np.vstack([task.homes, np.array([o.q for o in options]).reshape(-1, 6)])
        stops = ["Home"] * task.n_robots + [o.weld for o in options]
        given, reference = [], None
        if cfg.objective != "time":
            # the time objective's answer, planned first with its own repairs, is a candidate of the others: a
            # wear-aware plan is then never worse on its own measure than the time plan it is compared with,
            # whatever its own rounds found (its legs, re-routes included, become this plan's)
            key = (replace(cfg, objective="time"), _task_key(task))
            if key not in self._time_answers:
                self.reconfigured(key[0]).plan(task)
            answer, known, rerouted, reroutes, log, reference = self._time_answers[key]
            given = [answer]
            legs.known |= known
            legs.rerouted.update(rerouted)
            legs.reroutes.update(reroutes)
            legs.log += [{**e, "why": e["why"] + " (planning the time objective)"} for e in log]
        best = None
        for repair in range(cfg.cable_repairs + 1):
            plan = self._rounds(task, options, qs, stops, given, reference)
            # a repair keeps every candidate so far, ``given`` ones included (with the jammed leg re-routed, or
            # blocked, which drops them): its rounds look for better ones, they do not start over without them
            given = self.candidates
            if cfg.cable_repairs == 0:
                return self._finished(plan, task)
            self.replay(plan)
            plan.info.update(cable_replays=repair + 1)
            if best is None or len(plan.replay.jammed()) < len(best.replay.jammed()):
                best = plan
            jams = jammed_legs(plan, qs)
            if not jams or repair == cfg.cable_repairs:
                break
            for robot, i, j in jams:
                reroute(legs, self.station.home, self.names, robot, i, j, qs, stops,
                        "jammed a cable in the station replay", task.weld_time if j >= task.n_robots else 0.0)
        return self._finished(best, task)

    def _rounds(self, task: StationTask, options: list[WeldOption], qs: np.ndarray, stops: list[str],
                given: list[Assignment], reference: float | None) -> StationPlan:
        return solve_rounds(self, task, options, qs, stops, given, reference)

    def _finished(self, plan: StationPlan, task: StationTask) -> StationPlan:
        """``plan``, with a time plan's answer and the legs behind it kept for the other objectives."""
        if self.config.objective == "time":
            legs = self.legs
            self._time_answers[(self.config, _task_key(task))] = (
                plan.assignment, set(legs.known), dict(legs.rerouted), dict(legs.reroutes),
                [dict(e) for e in legs.log], plan.schedule.makespan)
        return plan

    def replay(self, plan: StationPlan, record_every: float = RECORD_EVERY) -> StationReplay:
        """``plan`` run in the cable simulator, every robot on one clock (kept as ``plan.replay``)."""
        return replay_plan(self.station, plan, self.config.cost_variant, self.bar, record_every, self.config.physics)

    def bar(self, label: str, total):
        """A progress bar from ``progress``, or one that shows nothing."""
        return (self.progress or no_bar)(label, total)


def _task_key(task: StationTask) -> tuple:
    """What a station task is, as a dictionary key: its welds, weld time, Homes and every option."""
    return (task.weld_names, float(task.weld_time), np.asarray(task.homes, dtype=float).tobytes(),
            tuple((o.weld, int(o.robot), np.asarray(o.q, dtype=float).tobytes())
                  for w in task.weld_names for o in task.options[w]))

