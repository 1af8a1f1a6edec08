"""Leg planning: each robot's collision-free legs between its Home and weld options (straight where valid, else
its leg planner; cached), their timed motions, and their cable runs with the robot alone (in worker processes
where a batch of them is known ahead: :meth:`LegBook.prefetch`)."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dresspack_gym.multi.replay import JAM_STRAIN
from dresspack_gym.multi.schedule import RobotSchedule, StationSchedule
from dresspack_gym.multi.tasks import StationTask, WeldOption
from dresspack_gym.physics.wear_cost import cost_function
from dresspack_gym.robots import time_law

from .config import RECORD_EVERY, no_bar
from .fast_routes import curve_valid
from .legs_up_front import move_key, own_moves, plan_leg, plan_moves
from .option_costs import OptionCosts


@dataclass(frozen=True)
class LegRun:
    """A leg run with its robot's cable alone in the station: settled at the leg's start, then the motion and the
    weld after it (if it ends at a weld)."""

    wear: float  # integral of the wear cost C over the motion and the weld [cost x s]
    max_tension: float  # [N]
    jammed: bool  # the cable was pulled beyond JAM_STRAIN
    start_settled: bool  # the settle at the start reached the equilibrium residual


class LegBook:
    """The legs a station plan uses. Legs are keyed by the configurations they join (not by node numbers, which
    belong to one option list), so a plan with other options never reads a wrong one. ``paths``, ``motions`` and
    ``runs`` are caches any plan may share (:meth:`fresh`); ``known`` (the legs this plan asked for: the solver
    treats only these as exact, so a plan never depends on what was planned before it), ``rerouted`` (legs
    re-routed after they jammed a cable, over the planned ones), ``reroutes`` (re-routes each has used) and ``log``
    (what was re-routed, and why) belong to one plan."""

    def __init__(self, leg_planners: list, limits: list[time_law.JointLimits], fly_by: bool, costs: OptionCosts,
                 settings: tuple, workers=None):
        self.planners, self.limits, self.fly_by, self.costs = leg_planners, limits, fly_by, costs
        self.settings = settings  # (station config, leg planner class, iterations, seed): what a leg depends on
        self.workers = workers  # a StationWorkers (prefetch, check_straight_moves), or None: all in this process
        self.paths: dict[tuple, np.ndarray | None] = {}
        self.motions: dict[tuple, time_law.PathMotion] = {}  # by robot and waypoints: each leg's timed motion
        self.runs: dict[tuple, LegRun] = {}  # by robot, waypoints and weld time: depends on nothing else
        self.known: set[tuple] = set()
        self.rerouted: dict[tuple, np.ndarray | None] = {}
        self.reroutes: dict[tuple, int] = {}
        self.log: list[dict] = []

    def fresh(self) -> LegBook:
        """A book for another plan: the same caches, none of this plan's legs known or re-routed."""
        other = copy.copy(self)
        other.rerouted, other.reroutes, other.log, other.known = {}, {}, [], set()
        return other

    def leg(self, robot: int, i: int, j: int, qs: np.ndarray) -> np.ndarray | None:
        """Robot ``robot``'s collision-free path from node i to node j (straight if valid, else its leg planner;
        cached); None if none is found within its iterations (the solver then treats the move as blocked)."""
        key = move_key(robot, qs[i], qs[j])
        if key in self.rerouted:
            return self.rerouted[key]
        self.known.add(key)
        if key not in self.paths:
            self.paths[key] = plan_leg(self.planners[robot], robot, qs[i], qs[j])
        return self.paths[key]

    def prefetch(self, moves: list[tuple[int, int, int, float]], qs: np.ndarray) -> None:
        """The paths, motions and cable runs :meth:`leg` and :meth:`run` will be asked for on ``moves`` (robot,
        from node, to node, weld time at the end), computed ahead in the worker processes (nothing without
        parallel workers). Only the caches are filled, with what this process would compute itself: which legs the
        plan knows, and the re-routes, stay with the calls that ask for them."""
        if self.workers is None or not self.workers.parallel:
            return
        wanted = {}
        for r, i, j, _ in moves:
            key = move_key(r, qs[i], qs[j])
            if key not in self.rerouted and key not in self.paths:
                wanted.setdefault(key, (r, qs[i], qs[j]))
        for key, path in zip(wanted, self.workers.map("leg", list(wanted.values()))):
            self.paths[key] = path
        runs = {}
        for r, i, j, weld in moves:
            key = move_key(r, qs[i], qs[j])
            leg = self.rerouted[key] if key in self.rerouted else self.paths[key]
            if leg is not None and (int(r), leg.tobytes(), float(weld)) not in self.runs:
                runs.setdefault((int(r), leg.tobytes(), float(weld)), (int(r), leg, float(weld)))
        for (r, leg, weld), (fly_by, run) in zip(runs.values(), self.workers.map("run", list(runs.values()))):
            key = (r, np.asarray(leg, dtype=float).tobytes())
            if key not in self.motions:  # the worker's verdict on the fly-by curve, not its check again
                self.motions[key] = time_law.PathMotion(leg, self.limits[r], fly_by=fly_by)
            self.runs[(r, leg.tobytes(), weld)] = run

    def motion(self, robot: int, leg: np.ndarray) -> time_law.PathMotion:
        """The timed motion of robot ``robot``'s ``leg`` (waypoints): flying by its via points if allowed and the
        rounded curve is collision-free, else stopping at each (cached)."""
        key = (int(robot), np.asarray(leg, dtype=float).tobytes())
        if key not in self.motions:
            motion = time_law.PathMotion(leg, self.limits[robot], fly_by=self.fly_by)
            if motion.fly_by and not curve_valid(motion, self.planners[robot].validity):
                motion = time_law.PathMotion(leg, self.limits[robot])
            self.motions[key] = motion
        return self.motions[key]

    def run(self, robot: int, leg: np.ndarray, weld_time: float) -> LegRun:
        """Robot ``robot``'s cable run along ``leg`` (waypoints) and ``weld_time`` seconds standing at its end,
        from settled at its start, the robot alone (cached): the leg's own wear, and whether it jams the cable."""
        leg = np.asarray(leg, dtype=float)
        key = (int(robot), leg.tobytes(), float(weld_time))
        if key not in self.runs:
            sim = self.costs.alone(robot)
            sim.reset(leg[None, 0])
            settled = sim.last_settle.converged
            motion = RobotSchedule.as_soon_as_possible(0, (), (leg,), self.limits[robot], 0.0,
                                                       motions=(self.motion(robot, leg),))
            program = StationSchedule((motion,), leg[None, -1])
            first = sim.cable_measures()
            times, samples = sim.follow(program.at, motion.end_time + weld_time, record_every=RECORD_EVERY)
            samples = [first, *samples]
            station = self.costs.station
            cost_fn, wear_cost = cost_function(self.costs.cost_variant), station.config.wear_cost
            rate = np.array([cost_fn(m[0], wear_cost).total for m in samples])
            tension = max(m[0].max_tension for m in samples)
            jam = JAM_STRAIN * station.config.robots[robot].dresspack.tensile_stiffness
            self.runs[key] = LegRun(float(np.trapezoid(rate, [0.0, *times])), float(tension),
                                    bool(tension > jam), bool(settled))
        return self.runs[key]

    def check_straight_moves(self, task: StationTask, options: list[WeldOption], bar=no_bar) -> None:
        """Every robot's straight moves between its Home and options, checked once: a valid one is its exact
        leg (what the OMPL connector would return), so only blocked moves stay estimates for the rounds."""
        R = task.n_robots
        qs = np.vstack([task.homes, np.array([o.q for o in options]).reshape(-1, 6)])
        robot_of = np.concatenate([np.arange(R), [o.robot for o in options]]).astype(int)
        weld_of = [None] * R + [o.weld for o in options]
        own = [np.flatnonzero(robot_of == r) for r in range(R)]
        pairs = [(r, i, j) for r in range(R) for i in own[r] for j in own[r]
                 if i != j and (weld_of[i] is None or weld_of[i] != weld_of[j])]
        todo = []
        for r, i, j in pairs:
            key = move_key(r, qs[i], qs[j])
            if key not in self.paths:
                todo.append((r, i, j))
            elif self.paths[key] is not None and len(self.paths[key]) == 2:  # checked before: a valid straight move
                self.known.add(key)
        bar = bar("checking straight moves", len(todo))
        if self.workers is not None and self.workers.parallel:
            valid = self.workers.map("straight", [(r, qs[i], qs[j]) for r, i, j in todo], bar)
        else:
            valid = []
            for r, i, j in todo:
                valid.append(self.planners[r].validity.segment_valid(qs[i], qs[j]))
                bar.update(1)
        for (r, i, j), ok in zip(todo, valid):
            if ok:
                key = move_key(r, qs[i], qs[j])
                self.paths[key] = np.array([qs[i], qs[j]])
                self.known.add(key)
        bar.close()

    def plan_every_move(self, task: StationTask, options: list[WeldOption], cache: Path | None = None,
                        workers: int = 2, bar=no_bar) -> None:
        """Every robot's moves between its Home and its options planned now, in ``workers`` processes, and known
        to the solver, which then times every move exactly (``scripts/studies/station_leg_bound.py`` bounds the plans
        over these legs). One direction is planned; the other is the same path backwards (the time law is
        symmetric in time, so it takes as long). ``cache``: a file the legs are appended to as they finish and
        read back by a later call with the same settings."""
        R = task.n_robots
        qs = np.vstack([task.homes, np.array([o.q for o in options]).reshape(-1, 6)])
        node_robot = np.concatenate([np.arange(R), [o.robot for o in options]]).astype(int)
        node_weld = np.concatenate([np.full(R, -1), [task.weld_names.index(o.weld) for o in options]]).astype(int)
        moves = own_moves(node_robot, node_weld)
        todo = [(r, i, j) for r, i, j in moves if move_key(r, qs[i], qs[j]) not in self.paths]
        bar = bar("planning every move up front", len(todo))
        legs = plan_moves(*self.settings, [(r, qs[i], qs[j]) for r, i, j in todo], workers=workers, cache=cache,
                          progress=bar)
        bar.close()
        for (r, i, j), leg in zip(todo, legs):
            self.paths[move_key(r, qs[i], qs[j])] = leg
        for r, i, j in moves:
            back = move_key(r, qs[j], qs[i])
            if back not in self.paths:
                leg = self.paths[move_key(r, qs[i], qs[j])]
                self.paths[back] = None if leg is None else leg[::-1].copy()
            self.known |= {move_key(r, qs[i], qs[j]), back}
