"""Planning a whole station: assign and order the welds over the robots, plan each chosen leg, coordinate the
robots by waits, verify, and run the result in the cable simulator.

Cheap estimates first, exact work on what is chosen: weld options are costed by their settled cable (one settle
per option, cached), travel by the time law of the straight move and its wear at the mean of its ends' settled
rates; the solver's chosen legs are then planned by OMPL (collision-free) and run with their robot's cable (from
settled at the leg's start, through the motion and the weld after it; cached); their real durations and
integrated wear replace the estimates, and the solver runs again until every chosen leg is exact. A leg whose
motion jams its robot's cable (drags it around the car body or its own links beyond the jam strain) is re-routed
or given up there. The plan is then run in the cable simulator with every robot on one clock; a leg behind a jam
found there is re-routed in the same way and the station planned again (``cable_repairs`` times at most): a
collision-free route is not yet a route the dresspack survives."""

from __future__ import annotations

import copy
import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import check_choice, check_integer, check_number
from dresspack_gym.multi.coordination import RobotPairDistance, coordinate, verify
from dresspack_gym.multi.replay import JAM_STRAIN, StationReplay, replay_station
from dresspack_gym.multi.schedule import RobotSchedule, StationSchedule
from dresspack_gym.multi.tasks import DEFAULT_WELD_TIME, StationTask, WeldOption, make_station_task
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.wear_cost import cost_function
from dresspack_gym.robots import time_law
from dresspack_gym.stations.station import Station

from .base import PlanningError
from .budget import DEFAULT_ITERATIONS
from .fast_routes import FastLegPlanner, curve_valid
from .ompl_planner import OmplPlanner
from .station_legs import move_key as _leg_key
from .station_legs import own_moves, plan_leg, plan_moves
from .station_solver import (
    BLOCKED_ESTIMATES,
    BOUND_WORK,
    DEFAULT_WORK,
    INTERLOCKS,
    LEG_ROUTES,
    MAKESPAN_SLACK,
    OBJECTIVES,
    PAIR_IMPROVEMENTS,
    PAIR_SOLVES,
    PAIR_WORK,
    SPAN_WEIGHT,
    Assignment,
    RoutingProblem,
    improve_by_pairs,
    lower_bound,
    relaxation_bound,
    solve,
    wear_relaxation_bound,
)

EXACT_TOLERANCE = 0.02  # a chosen leg whose planned duration exceeds its estimate by more is re-solved with it
# rounds allowed, as a multiple of exact_rounds, while no solved answer has every leg planned (legs that jam their
# cable are blocked as they are found, so an answer can lose a leg after it was chosen)
EXTRA_ROUNDS = 3
BLOCKED = 1e4  # [s] the travel time of a move OMPL found no path for: the solver avoids it
# Two robots' weld options closer than this [m] are a conflict (they cannot weld at once; their legs around
# them likely meet): CONFLICT_WAIT x (weld time + a typical leg) is the time the solver keeps between two such
# welds' starts (for the first robot to weld and leave before the second arrives: an interlock zone), or, in
# its charged model, the wait it charges the pair (station_solver.INTERLOCKS)
CONFLICT_DISTANCE = 0.15
CONFLICT_WAIT = 1.0
# Re-routes a leg that jammed its cable gets before it counts as blocked: the leg planner with another seed (a via
# point or OMPL route it had not drawn), then through the robot's Home (where the dresspack is laid out to hang
# freely)
REROUTES = ("reseeded", "via_home")
RESEED = 7919  # seed offset of a re-routed leg's plan (any fixed number: another stream, deterministically)
# [s] sampling of the wear cost C along a simulated leg and in the station replay (the integral is over these
# samples; one value for both, so a leg's simulated wear and its part of the replay are the same measure)
RECORD_EVERY = 0.05
# how a leg whose straight move is blocked is planned (StationPlanConfig.leg_route): "fastest", the straight move
# else one taught via point else OMPL, shortened under the time law (agents/fast_routes.py); "ompl", OMPL's
# RRTConnect path as the single-robot ``ompl`` planner returns it (the station planner's legs until stop 36: on
# side_framing_4r its detours took 1.6x as long)
LEG_PLANNERS = dict(zip(LEG_ROUTES, (FastLegPlanner, OmplPlanner)))


@dataclass(frozen=True)
class LegRun:
    """A leg run with its robot's cable alone in the station: settled at the leg's start, then the motion and the
    weld after it (if it ends at a weld)."""

    wear: float  # integral of the wear cost C over the motion and the weld [cost x s]
    max_tension: float  # [N]
    jammed: bool  # the cable was pulled beyond JAM_STRAIN
    start_settled: bool  # the settle at the start reached the equilibrium residual


@dataclass(frozen=True)
class StationPlanConfig:
    """Settings of a station plan (defaults: what ``dresspack station-plan`` uses)."""

    objective: str = "time"
    weld_time: float = DEFAULT_WELD_TIME
    work: float = DEFAULT_WORK  # solver work budget per solve (CP-SAT deterministic seconds)
    time_budget: float | None = None  # optional wall-clock cap per solve [s]
    costed_options: int = 8  # per weld and robot: IK options (nearest Home first) whose settled cable is costed
    kept_options: int = 2  # per weld and robot: options the solver chooses from (half nearest Home, half cheapest)
    iterations: int = DEFAULT_ITERATIONS  # OMPL iterations per leg
    # solve -> plan chosen legs -> re-solve rounds; more (up to EXTRA_ROUNDS x) while no answer has every leg planned
    exact_rounds: int = 2
    # then solves of two robots at a time (station_solver.improve_by_pairs; 0: none), each better answer coordinated
    pair_solves: int = PAIR_SOLVES
    # CP-SAT deterministic seconds proving the makespan bound (station_solver.relaxation_bound); it changes only
    # the bound, never the plan
    bound_work: float = BOUND_WORK
    makespan_slack: float = MAKESPAN_SLACK
    seed: int = 0
    cost_variant: str = "thesis"
    fixed_assignment: bool = False
    welds: tuple[str, ...] | None = None
    # station replays whose jammed legs are re-routed before the plan is final (0: no replay inside planning)
    cable_repairs: int = 3
    # the solver's time for a move not planned yet (blocked as a straight move): "planned_ratio", its
    # straight-move time x the median slow-down of the detours planned so far, or "straight", that time alone (a
    # lower bound: the solver then favours unplanned detours, and on side_framing_4r its time plan took 39.4 s
    # against 34.2 s)
    blocked_estimate: str = "planned_ratio"
    leg_route: str = "fastest"  # LEG_PLANNERS
    # legs fly by their via points (time_law.PathMotion) where the rounded curve is still collision-free (checked
    # like a path: agents/fast_routes.curve_valid), else stop at each; False: every leg stops at each
    fly_by: bool = True
    # the wear and balanced objectives: every robot's moves between its Home and options planned before the rounds
    # (plan_every_move, in ``leg_workers`` processes), so their solver times every move exactly and chooses among
    # legs it knows (side_framing_4r's wear plan: 3,852 against 4,021, stop 43). The time objective plans its legs
    # lazily whatever this says: with every move exact its answers packed the robots tighter than coordination could
    # keep (36.1 s against 24.7 s, stop 42)
    legs_up_front: bool = False
    leg_workers: int = 2

    def __post_init__(self):
        check_choice("objective", self.objective, OBJECTIVES)
        check_choice("leg_route", self.leg_route, LEG_ROUTES)
        check_choice("blocked_estimate", self.blocked_estimate, BLOCKED_ESTIMATES)
        check_number(self.weld_time, "weld_time", lo=0.0, hi=600.0, unit="s")
        check_number(self.work, "work", lo=0.0, lo_open=True, hi=1e6)
        if self.time_budget is not None:
            check_number(self.time_budget, "time_budget", lo=0.0, lo_open=True, hi=86400.0, unit="s")
        check_integer(self.costed_options, "costed_options", lo=1, hi=1000)
        check_integer(self.kept_options, "kept_options", lo=1, hi=100)
        check_integer(self.exact_rounds, "exact_rounds", lo=1, hi=100)
        check_integer(self.pair_solves, "pair_solves", lo=0, hi=10_000)
        check_number(self.bound_work, "bound_work", lo=0.0, lo_open=True, hi=1e6)
        check_integer(self.cable_repairs, "cable_repairs", lo=0, hi=100)
        check_integer(self.leg_workers, "leg_workers", lo=1, hi=64)
        check_number(self.makespan_slack, "makespan_slack", lo=0.0, hi=10.0)
        check_integer(self.seed, "seed", lo=0, hi=2 ** 32 - 1)
        cost_function(self.cost_variant)


@dataclass
class StationPlan:
    """A planned station: the task, the chosen options per robot, the coordinated schedule, its checks."""

    task: StationTask
    names: list[str]  # robot names, by index
    options: list[WeldOption]  # node k -> option (nodes 0..R-1 are the Homes: None)
    assignment: Assignment
    schedule: StationSchedule
    coordination: dict
    verification: dict
    bound: dict
    config: StationPlanConfig
    replay: StationReplay | None = None
    info: dict | None = None
    # the wear objective: the least wear estimate any routes over these options could have within its makespan
    # cap (station_solver.wear_relaxation_bound on straight-move times)
    wear_bound: dict | None = None

    def robot_welds(self) -> dict[str, list[str]]:
        names = self.names
        return {names[s.robot]: list(s.welds) for s in self.schedule.robots}

    def summary(self) -> dict:
        s = {
            "objective": self.config.objective,
            "makespan": round(self.schedule.makespan, 3),
            "makespan_lower_bound": round(self.bound["bound"], 3),
            "gap_to_bound": round(self.schedule.makespan / self.bound["bound"] - 1.0, 4),
            "lower_bounds": {k: round(v, 3) if isinstance(v, float) else v for k, v in self.bound.items()},
            "total_wait": round(self.schedule.total_wait(), 3),
            "estimate": self.assignment.estimate,
            "coordination": self.coordination,
            "verification": self.verification,
            "welds": self.robot_welds(),
            "robot_end_times": {self.names[s.robot]: round(s.end_time, 3) for s in self.schedule.robots},
            "info": self.info or {},
        }
        if self.wear_bound is not None:
            s["wear_estimate_bound"] = {k: round(v, 3) if isinstance(v, float) else v
                                        for k, v in self.wear_bound.items()}
        if self.replay is not None:
            s["replay"] = self.replay.summary(self.names)
            split = self.replay.wear_split(self.schedule)
            s["replay"]["wear_split"] = {self.names[i]: v for i, v in split.items()}
        return s


class StationPlanner:
    """Plans a station's welds over its robots (see the module docstring); ``progress(label, total)`` may give
    a tqdm-like bar factory."""

    def __init__(self, station: Station, config: StationPlanConfig = StationPlanConfig(), progress=None):
        self.station = station
        self.config = config
        self.progress = progress
        self.leg_planners = [LEG_PLANNERS[config.leg_route](station, r, iterations=config.iterations, seed=config.seed)
                             for r in range(station.n_robots)]
        cfg = station.config
        self.limits = [r.robot.joint_motion_limits.at_speed(cfg.simulation.speed_fraction) for r in cfg.robots]
        self._rates: dict[tuple, float] = {}
        self._unconverged: set[tuple] = set()  # cost settles that ended above the equilibrium residual (flagged)
        # legs and conflicts are keyed by the configurations they join (not by node numbers, which belong to
        # one option list), so a reconfigured planner with other options never reads a wrong one
        self._legs: dict[tuple, np.ndarray | None] = {}
        self._conflicts: dict[bytes, np.ndarray] = {}
        self._relaxations: dict[bytes, dict] = {}  # relaxation bounds (makespan, wear) of straight-move problems
        self._sub_sims: dict[int, CableSimulator] = {}
        # legs re-routed after they jammed a cable, over the planned ones (per planner: one objective's replays
        # do not change another's plan), and the re-routes each has used
        self._rerouted: dict[tuple, np.ndarray | None] = {}
        self._reroutes: dict[tuple, int] = {}
        self._reroute_log: list[dict] = []  # what was re-routed, and why (a plan's info["rerouted_legs"])
        self._leg_runs: dict[tuple, LegRun] = {}  # by robot, waypoints and weld time: depends on nothing else
        self._motions: dict[tuple, time_law.PathMotion] = {}  # by robot and waypoints: each leg's timed motion
        # the legs this planner has asked for: the solver treats only these as exact. The caches above may hold
        # more (a reconfigured planner shares them), and using those would make a plan depend on what was
        # planned before it
        self._known: set[tuple] = set()
        # finished time plans by (config, task): the wear and balanced objectives take the time objective's
        # answer as a candidate, and the command has usually just planned it with the same settings (a plan
        # depends only on these, so the answer and the legs it asked for are reused, not planned again)
        self._time_answers: dict[tuple, tuple] = {}
        self._candidates: list[Assignment] = []  # the last rounds' candidates (a cable repair keeps them)
        # coordinated schedules by routes and their legs: the pair search's kept answer is coordinated again in _best
        self._coordinations: dict[tuple, tuple] = {}

    def reconfigured(self, config: StationPlanConfig) -> StationPlanner:
        """A planner with ``config`` that keeps this one's settled-cable costs and planned legs (same station,
        seed, OMPL iterations, leg route and cost variant: the cached answers do not depend on anything else)."""
        if (config.seed, config.iterations, config.cost_variant, config.leg_route, config.fly_by) != \
                (self.config.seed, self.config.iterations, self.config.cost_variant, self.config.leg_route,
                 self.config.fly_by):
            return StationPlanner(self.station, config, self.progress)
        other = copy.copy(self)  # shares the caches
        other.config = config
        other._rerouted, other._reroutes, other._reroute_log, other._known = {}, {}, [], set()
        return other

    # -------------------------------------------------------------------------- costs
    def cost_rate(self, robot: int, q: np.ndarray) -> float:
        """The wear cost rate C of robot ``robot``'s cable settled at ``q`` (the robot alone in the station)."""
        key = (int(robot), *(float(x) for x in np.round(q, 9)))
        if key not in self._rates:
            sim = self._alone(robot)
            sim.reset(np.asarray(q)[None])
            if not sim.last_settle.converged:
                self._unconverged.add(key)
            self._rates[key] = cost_function(self.config.cost_variant)(sim.measures(),
                                                                       self.station.config.wear_cost).total
        return self._rates[key]

    def _alone(self, robot: int) -> CableSimulator:
        """A simulator of the station with robot ``robot`` alone (the other robots and their cables removed)."""
        sim = self._sub_sims.get(robot)
        if sim is None:
            cfg = self.station.config
            alone = replace(cfg, robots=(cfg.robots[robot],), weld_points=())
            sim = self._sub_sims[robot] = CableSimulator(Station(alone))
        return sim

    def leg_run(self, robot: int, leg: np.ndarray, weld_time: float) -> LegRun:
        """Robot ``robot``'s cable run along ``leg`` (waypoints) and ``weld_time`` seconds standing at its end,
        from settled at its start, the robot alone (cached): the leg's own wear, and whether it jams the cable."""
        leg = np.asarray(leg, dtype=float)
        key = (int(robot), leg.tobytes(), float(weld_time))
        if key not in self._leg_runs:
            sim = self._alone(robot)
            sim.reset(leg[None, 0])
            settled = sim.last_settle.converged
            motion = RobotSchedule.as_soon_as_possible(0, (), (leg,), self.limits[robot], 0.0,
                                                       motions=(self.leg_motion(robot, leg),))
            program = StationSchedule((motion,), leg[None, -1])
            first = sim.cable_measures()
            times, samples = sim.follow(program.at, motion.end_time + weld_time, record_every=RECORD_EVERY)
            samples = [first, *samples]
            cost_fn, wear_cost = cost_function(self.config.cost_variant), self.station.config.wear_cost
            rate = np.array([cost_fn(m[0], wear_cost).total for m in samples])
            tension = max(m[0].max_tension for m in samples)
            jam = JAM_STRAIN * self.station.config.robots[robot].dresspack.tensile_stiffness
            self._leg_runs[key] = LegRun(float(np.trapezoid(rate, [0.0, *times])), float(tension),
                                         bool(tension > jam), bool(settled))
        return self._leg_runs[key]

    def load_rates(self, path: Path) -> None:
        """Costs saved by :meth:`save_rates` (rows without their settle's verdict are recomputed)."""
        if path.is_file():
            for row in json.loads(path.read_text()):
                if "converged" in row:
                    key = tuple(row["key"])
                    self._rates[key] = row["rate"]
                    if not row["converged"]:
                        self._unconverged.add(key)

    def save_rates(self, path: Path) -> None:
        path.write_text(json.dumps([{"key": list(k), "rate": v, "converged": k not in self._unconverged}
                                    for k, v in self._rates.items()]))

    def unconverged_options(self, options: list[WeldOption]) -> list[str]:
        """The welds among ``options`` whose option's cost comes from a settle that did not reach equilibrium."""
        return sorted({o.weld for o in options
                       if (int(o.robot), *(float(x) for x in np.round(o.q, 9))) in self._unconverged})

    def cheapest_weld_wear(self, task: StationTask) -> float:
        """Σ over the welds of weld time x the lowest settled cost rate among its costed options: what the welding
        alone would wear with every weld at its cheapest option (a reference for a plan's welding wear)."""
        return float(sum(task.weld_time * min(self.cost_rate(r, o.q) for r in task.candidates(w)
                                              for o in self._costed(task, w, r))
                         for w in task.weld_names))

    def _costed(self, task: StationTask, weld: str, robot: int) -> list[WeldOption]:
        """The options of ``weld`` by ``robot`` whose settled cable is costed: the first ``costed_options``
        (nearest Home first)."""
        return [o for o in task.options[weld] if o.robot == robot][:self.config.costed_options]

    def _choose_options(self, task: StationTask) -> list[WeldOption]:
        """Per weld and robot, the options the solver sees: the nearest Home and the cheapest of those costed."""
        cfg = self.config
        jobs = [(w, r, self._costed(task, w, r)) for w in task.weld_names for r in task.candidates(w)]
        bar = self._bar("costing weld options (settled cable)", sum(len(j[2]) for j in jobs))
        kept = []
        for w, r, opts in jobs:
            rates = []
            for o in opts:
                rates.append(self.cost_rate(r, o.q))
                bar.update(1)
            near = list(range(min(len(opts), (cfg.kept_options + 1) // 2)))
            cheap = [int(i) for i in np.argsort(rates, kind="stable") if int(i) not in near]
            for i in sorted(near + cheap[:cfg.kept_options - len(near)]):
                kept.append(opts[i])
        bar.close()
        return kept

    def problem(self, task: StationTask, options: list[WeldOption]) -> RoutingProblem:
        R = task.n_robots
        qs = np.vstack([task.homes, np.array([o.q for o in options]).reshape(-1, 6)])
        node_robot = np.concatenate([np.arange(R), [o.robot for o in options]]).astype(int)
        index = {w: k for k, w in enumerate(task.weld_names)}
        node_weld = np.concatenate([np.full(R, -1), [index[o.weld] for o in options]]).astype(int)
        straight = self.straight_times(qs)
        travel = straight.copy()
        node_of = {}
        for n, (r, q) in enumerate(zip(node_robot, qs)):
            node_of.setdefault((int(r), q.tobytes()), []).append(n)
        simulated = np.full(travel.shape, np.nan)
        weld_after = np.where(node_weld >= 0, task.weld_time, 0.0)
        planned = {k: self._legs[k] for k in self._known if k in self._legs}
        exact, detour = np.zeros(travel.shape, bool), np.zeros(travel.shape, bool)
        for (r, qa, qb), leg in {**planned, **self._rerouted}.items():  # planned legs are exact
            for i in node_of.get((r, qa), ()):
                for j in node_of.get((r, qb), ()):
                    exact[r, i, j], detour[r, i, j] = True, leg is not None and len(leg) > 2
                    travel[r, i, j] = BLOCKED if leg is None else self.leg_motion(r, leg).duration
                    run = None if leg is None else self._leg_runs.get((r, leg.tobytes(), float(weld_after[j])))
                    if run is not None:
                        simulated[r, i, j] = run.wear
        if self.config.blocked_estimate == "planned_ratio" and detour.any():
            # every unplanned move is blocked (the valid straight ones are planned legs already): estimate it
            # as its straight move slowed like the detours planned so far, not at the straight move's time
            ratio = float(np.median(travel[detour] / np.maximum(straight[detour], 1e-9)))
            mine = node_robot[None, :] == np.arange(R)[:, None]  # (R, N): robot r's Home and options
            own = mine[:, :, None] & mine[:, None, :]
            travel = np.where(own & ~exact, travel * max(ratio, 1.0), travel)
        rates = np.array([self.cost_rate(r, q) for r, q in zip(node_robot, qs)])
        key = qs.tobytes() + node_robot.tobytes()
        if key not in self._conflicts:
            self._conflicts[key] = self._find_conflicts(qs, node_robot)
        own = [travel[r][np.ix_(node_robot == r, node_robot == r)] for r in range(R)]
        typical_leg = float(np.median(np.concatenate([t[t > 0] for t in own if (t > 0).any()] or [[0.0]])))
        return RoutingProblem(travel, rates, node_robot, node_weld, task.weld_time, len(task.weld_names),
                              self._conflicts[key], CONFLICT_WAIT * (task.weld_time + typical_leg), simulated)

    def _find_conflicts(self, qs: np.ndarray, node_robot: np.ndarray) -> np.ndarray:
        """Option pairs of different robots whose robots, both at their options (the rest at Home), come within
        CONFLICT_DISTANCE: welding them at once is impossible, and the legs around them likely meet too."""
        pairs = RobotPairDistance(self.station)
        poses = self.station.home.copy()
        R = self.station.n_robots
        out = []
        nodes = np.arange(R, len(qs))
        for a in nodes:
            for b in nodes[nodes > a]:
                ra, rb = int(node_robot[a]), int(node_robot[b])
                if ra == rb:
                    continue
                poses[:] = self.station.home
                poses[ra], poses[rb] = qs[a], qs[b]
                pairs.pose(poses)
                if pairs.distance(ra, rb, cap=CONFLICT_DISTANCE) < CONFLICT_DISTANCE:
                    out.append((int(a), int(b)))
        return np.array(out, dtype=int).reshape(-1, 2)

    # -------------------------------------------------------------------------- legs
    def check_straight_moves(self, task: StationTask, options: list[WeldOption]) -> None:
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
            key = _leg_key(r, qs[i], qs[j])
            if key not in self._legs:
                todo.append((r, i, j))
            elif self._legs[key] is not None and len(self._legs[key]) == 2:  # checked before: a valid straight move
                self._known.add(key)
        bar = self._bar("checking straight moves", len(todo))
        for r, i, j in todo:
            if self.leg_planners[r].validity.segment_valid(qs[i], qs[j]):
                key = _leg_key(r, qs[i], qs[j])
                self._legs[key] = np.array([qs[i], qs[j]])
                self._known.add(key)
            bar.update(1)
        bar.close()

    def leg(self, robot: int, i: int, j: int, qs: np.ndarray) -> np.ndarray | None:
        """Robot ``robot``'s collision-free path from node i to node j (straight if valid, else OMPL; cached);
        None if OMPL finds none within its iterations (the solver then treats the move as blocked)."""
        key = _leg_key(robot, qs[i], qs[j])
        if key in self._rerouted:
            return self._rerouted[key]
        self._known.add(key)
        if key not in self._legs:
            self._legs[key] = plan_leg(self.leg_planners[robot], robot, qs[i], qs[j])
        return self._legs[key]

    def plan_every_move(self, task: StationTask, options: list[WeldOption], cache: Path | None = None,
                        workers: int = 2) -> None:
        """Every robot's moves between its Home and its options planned now, in ``workers`` processes, and known
        to the solver, which then times every move exactly (``scripts/station_leg_bound.py`` bounds the plans over
        these legs). One direction is planned; the other is the same path backwards (the time law is symmetric
        in time, so it takes as long). ``cache``: a file the legs are appended to as they finish and read back
        by a later call with the same settings."""
        R = task.n_robots
        qs = np.vstack([task.homes, np.array([o.q for o in options]).reshape(-1, 6)])
        node_robot = np.concatenate([np.arange(R), [o.robot for o in options]]).astype(int)
        node_weld = np.concatenate([np.full(R, -1), [task.weld_names.index(o.weld) for o in options]]).astype(int)
        moves = own_moves(node_robot, node_weld)
        todo = [(r, i, j) for r, i, j in moves if _leg_key(r, qs[i], qs[j]) not in self._legs]
        bar = self._bar("planning every move up front", len(todo))
        cfg = self.config
        legs = plan_moves(self.station.config, LEG_PLANNERS[cfg.leg_route], cfg.iterations, cfg.seed,
                          [(r, qs[i], qs[j]) for r, i, j in todo], workers=workers, cache=cache, progress=bar)
        bar.close()
        for (r, i, j), leg in zip(todo, legs):
            self._legs[_leg_key(r, qs[i], qs[j])] = leg
        for r, i, j in moves:
            back = _leg_key(r, qs[j], qs[i])
            if back not in self._legs:
                leg = self._legs[_leg_key(r, qs[i], qs[j])]
                self._legs[back] = None if leg is None else leg[::-1].copy()
            self._known |= {_leg_key(r, qs[i], qs[j]), back}

    def leg_motion(self, robot: int, leg: np.ndarray) -> time_law.PathMotion:
        """The timed motion of robot ``robot``'s ``leg`` (waypoints): flying by its via points if the config allows
        and the rounded curve is collision-free, else stopping at each (cached)."""
        key = (int(robot), np.asarray(leg, dtype=float).tobytes())
        if key not in self._motions:
            motion = time_law.PathMotion(leg, self.limits[robot], fly_by=self.config.fly_by)
            if motion.fly_by and not curve_valid(motion, self.leg_planners[robot].validity):
                motion = time_law.PathMotion(leg, self.limits[robot])
            self._motions[key] = motion
        return self._motions[key]

    def _plan_chosen_legs(self, problem: RoutingProblem, assignment: Assignment, qs: np.ndarray,
                          stops: list[str]) -> int:
        """Plan every leg of the assignment and run it with its robot's cable (a leg that jams the cable is
        re-routed or blocked); the number that took longer, or (objectives with wear) wore more, than estimated."""
        changed = 0
        for r, route in enumerate(assignment.routes):
            path = [r, *route, r]
            wear = problem.leg_wear(r)
            for a, b in zip(path[:-1], path[1:]):
                estimate = problem.travel[r, a, b]
                leg = self.leg(r, a, b, qs)
                weld = problem.weld_time if problem.node_weld[b] >= 0 else 0.0
                if leg is not None and self.leg_run(r, leg, weld).jammed:
                    self._reroute(r, a, b, qs, stops, "jammed its cable alone", weld)
                    leg = self.leg(r, a, b, qs)
                real = BLOCKED if leg is None else self.leg_motion(r, leg).duration
                changed += real > estimate * (1 + EXACT_TOLERANCE) + 1e-6
                if leg is not None and self.config.objective != "time":
                    changed += self.leg_run(r, leg, weld).wear > wear[a, b] * (1 + EXACT_TOLERANCE) + 1e-6
        return changed

    def straight_times(self, qs: np.ndarray) -> np.ndarray:
        """(R, N, N) [s] each robot's straight-move time between the nodes ``qs``: a lower bound of any motion
        between them (for the shipped robots' proportional limits the synchronised straight move takes exactly
        its slowest joint's minimum time, and no path is shorter for that joint)."""
        return np.stack([time_law.segment_durations(qs[None, :, :] - qs[:, None, :], self.limits[r])
                         for r in range(len(self.limits))])

    def _bound(self, problem: RoutingProblem, straight: np.ndarray, solver_bound: float) -> dict:
        """Makespan lower bounds of any plan over these options, all on the straight-move times (not the planned
        legs' times: a planned path is one way, not the fastest): the analytic ones (station_solver.lower_bound),
        CP-SAT's bound on the routes without conflicts (``relaxation``, station_solver.relaxation_bound), and
        the rounds' (``solver``: CP-SAT's bound, from rounds whose every leg time was a straight move)."""
        relaxed = replace(problem, travel=straight)
        b = lower_bound(relaxed)
        key = straight.tobytes() + problem.node_robot.tobytes() + problem.node_weld.tobytes() + \
            np.float64(problem.weld_time).tobytes() + np.float64(self.config.bound_work).tobytes()
        if key not in self._relaxations:  # the same for every objective: solved once
            self._relaxations[key] = relaxation_bound(relaxed, work=self.config.bound_work, seed=self.config.seed)
        b.update(self._relaxations[key], solver=solver_bound)
        b["bound"] = max(b["bound"], solver_bound, b["relaxation"] or 0.0)
        return b

    def _wear_bound(self, problem: RoutingProblem, straight: np.ndarray, cap: float) -> dict:
        """The least wear estimate of any routes over these options within ``cap`` [s], on straight-move times
        (station_solver.wear_relaxation_bound; cached like the makespan's relaxation). An estimate's bound, not the
        replay's: the estimate charges a move its ends' mean settled rate, and on side_framing_4r it reads 0.7 %
        (wear plan) and 5.4 % (time plan) below their replays."""
        key = (straight.tobytes() + problem.node_robot.tobytes() + problem.node_weld.tobytes()
               + problem.cost_rate.tobytes() + np.array([problem.weld_time, cap, self.config.bound_work]).tobytes())
        if key not in self._relaxations:
            self._relaxations[key] = wear_relaxation_bound(replace(problem, travel=straight), cap,
                                                           work=self.config.bound_work, seed=self.config.seed)
        return self._relaxations[key]

    def _schedule(self, task: StationTask, options: list[WeldOption], routes, qs) -> StationSchedule:
        R = task.n_robots
        schedules = []
        for r, route in enumerate(routes):
            if not route:  # a robot without welds stays Home (and is still an obstacle to the others)
                schedules.append(RobotSchedule.as_soon_as_possible(r, [], [np.array([task.homes[r]] * 2)],
                                                                   self.limits[r], task.weld_time))
                continue
            path = [r, *route, r]
            legs = [self.leg(r, a, b, qs) for a, b in zip(path[:-1], path[1:])]
            schedules.append(RobotSchedule.as_soon_as_possible(r, [options[n - R].weld for n in route], legs,
                                                               self.limits[r], task.weld_time,
                                                               motions=[self.leg_motion(r, g) for g in legs]))
        return StationSchedule(tuple(schedules), task.homes)

    def _coordinated(self, problem: RoutingProblem, routes, task: StationTask, options: list[WeldOption],
                     qs: np.ndarray, pairs: RobotPairDistance, cap: float = np.inf):
        """``routes`` with their planned legs, coordinated: (schedule, coordination info, wear with the waits: at
        the waiting robot's stop, and the cables hanging at Home until the coordinated makespan), or None when no
        robot order ends before ``cap``. A resolved one is cached by the routes and their legs (it depends on
        nothing else: the best order below one cap is the best below any cap above it)."""
        legs = tuple(None if (g := self.leg(r, a, b, qs)) is None else g.tobytes()
                     for r, route in enumerate(routes) for a, b in zip([r, *route], [*route, r]))
        key = (_routes_key(routes), legs, qs.tobytes())
        if key in self._coordinations:
            schedule, info = self._coordinations[key]
            if schedule.makespan >= cap:
                return None
            info = dict(info)
        else:
            schedule, info = coordinate(self.station, self._schedule(task, options, routes, qs), pairs, cap=cap)
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

    def _best(self, problem: RoutingProblem, candidates: list[Assignment], task: StationTask,
              options: list[WeldOption], qs: np.ndarray, pairs: RobotPairDistance, reference: float | None = None):
        """The best of the solved assignments once their legs are planned and their robots coordinated: the
        solver saw straight-move times (lower bounds of planned legs) and only a guess of the waits, so a later
        round's answer, or the wear objective's, can turn out the worse one. Wear counts the waits at the
        waiting robot's stop and the cables hanging at Home until the coordinated makespan. The wear objective
        keeps within its slack of ``reference`` (the time plan's makespan: the plan it is compared with), or of
        its fastest candidate without one. Returns (assignment, coordinated schedule, coordination info)."""
        cfg = self.config
        unique = list({tuple(map(tuple, a.routes)): a for a in candidates}.values())
        exact = [Assignment(a.routes, {**a.estimate, **problem.evaluate(a.routes)}, a.objective) for a in unique]
        exact = [a for a in exact if a.estimate["makespan"] < BLOCKED]
        if not exact:
            raise PlanningError(f"no assignment found whose every leg OMPL could plan within {cfg.iterations} "
                                f"iterations in {EXTRA_ROUNDS * cfg.exact_rounds} rounds (raise --iterations)")
        scored = []
        bar = self._bar("coordinating the candidate plans", len(exact))
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
            got = self._coordinated(problem, a.routes, task, options, qs, pairs, cap=beat)
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
        # side_framing_4r) shrank its room to nothing (stop 37)
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

    # -------------------------------------------------------------------------- plan
    def plan(self, task: StationTask | None = None, cache: Path | None = None,
             leg_cache: Path | None = None) -> StationPlan:
        """Plan the station; with ``cable_repairs`` > 0 the plan is replayed with its cables (``plan.replay``), a
        leg that jammed a cable is re-routed (:data:`REROUTES`, then blocked) and the station planned again. The
        answer is the first plan without a jam, else the one with the fewest jammed cables (flagged in its
        replay); ``info["rerouted_legs"]`` lists what was changed (legs that jammed their cable alone are
        re-routed while planning, with or without repairs). ``cache``: the option costs' file; ``leg_cache``: the
        file the legs planned up front go to (``legs_up_front``), read back by a later run."""
        cfg = self.config
        if task is None:
            task = make_station_task(self.station, lambda r: self.leg_planners[r].validity.checker.collides,
                                     list(cfg.welds) if cfg.welds is not None else None, weld_time=cfg.weld_time,
                                     fixed_assignment=cfg.fixed_assignment)
        if cache is not None:
            self.load_rates(cache)
        options = self._choose_options(task)
        if cache is not None:
            self.save_rates(cache)
        self.check_straight_moves(task, options)
        if cfg.legs_up_front and cfg.objective != "time":
            self.plan_every_move(task, options, leg_cache, workers=cfg.leg_workers)
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
            self._known |= known
            self._rerouted.update(rerouted)
            self._reroutes.update(reroutes)
            self._reroute_log += [{**e, "why": e["why"] + " (planning the time objective)"} for e in log]
        best = None
        for repair in range(cfg.cable_repairs + 1):
            plan = self._plan_legs(task, options, qs, stops, given, reference)
            # a repair keeps every candidate so far, ``given`` ones included (with the jammed leg re-routed, or
            # blocked, which drops them): its rounds look for better ones, they do not start over without them
            given = self._candidates
            if cfg.cable_repairs == 0:
                return self._finished(plan, task)
            self.replay(plan)
            plan.info.update(cable_replays=repair + 1)
            if best is None or len(plan.replay.jammed()) < len(best.replay.jammed()):
                best = plan
            jams = self.jammed_legs(plan, qs)
            if not jams or repair == cfg.cable_repairs:
                break
            for robot, i, j in jams:
                self._reroute(robot, i, j, qs, stops, "jammed a cable in the station replay",
                              task.weld_time if j >= task.n_robots else 0.0)
        return self._finished(best, task)

    def _finished(self, plan: StationPlan, task: StationTask) -> StationPlan:
        """``plan``, with a time plan's answer and the legs behind it kept for the other objectives."""
        if self.config.objective == "time":
            self._time_answers[(self.config, _task_key(task))] = (
                plan.assignment, set(self._known), dict(self._rerouted), dict(self._reroutes),
                [dict(e) for e in self._reroute_log], plan.schedule.makespan)
        return plan

    def _plan_legs(self, task: StationTask, options: list[WeldOption], qs: np.ndarray, stops: list[str],
                   given: list[Assignment] = (), reference: float | None = None) -> StationPlan:
        """Solve, plan the chosen legs, re-solve with their exact times (``exact_rounds``); coordinate; verify.
        ``given``: answers found elsewhere whose legs are planned, candidates beside this objective's;
        ``reference``: the time plan's makespan, which the wear objective's slack is measured from."""
        cfg = self.config
        rounds, solves, candidates, bound, wear_failures = 0, 0, list(given), 0.0, 0
        bar = self._bar("solve, plan the chosen legs (rounds, at most)", cfg.exact_rounds)
        fastest = chosen = None
        answers = {}  # the previous round's fastest answer per interlock model
        straight = self.straight_times(qs)
        while True:
            problem = self.problem(task, options)
            # the fastest answer two ways: conflicting welds scheduled apart, or charged a wait and so avoided
            # (whose answers' legs cross less); both are candidates, and the coordination of their planned legs
            # decides. Later rounds start from the previous answer (still feasible: only leg times changed)
            for model in INTERLOCKS:
                previous_answer = answers.get(model)
                answers[model] = solve(problem, "time", work=cfg.work, seed=cfg.seed, time_limit=cfg.time_budget,
                                       start=previous_answer.routes if previous_answer is not None else None,
                                       interlocks=model)
                solves += 1
            fastest = min(answers.values(), key=lambda a: (a.estimate["timed_makespan"], a.estimate["time"]))
            if np.array_equal(problem.travel, straight):  # a bound of any plan only while no leg is a planned path
                bound = max(bound, fastest.estimate.get("makespan_bound", 0.0))
            previous = chosen.routes if chosen is not None and chosen is not fastest else None
            chosen = fastest
            if cfg.objective in ("wear", "time"):
                # the least-wear answer within the slack is also a candidate of the time objective: the solver
                # times most legs by estimates, and an answer of shorter, cheaper legs can turn out the faster
                # one once they are planned.
                # Started from the fastest answer, which is within the cap by construction: never infeasible
                try:
                    chosen = solve(problem, "wear", work=cfg.work, seed=cfg.seed, time_limit=cfg.time_budget,
                                   makespan_cap=fastest.estimate["timed_makespan"] * (1 + cfg.makespan_slack),
                                   start=fastest.routes)
                except ConfigError:  # the budget ran out before CP-SAT took the start: keep the fastest
                    wear_failures += 1
                solves += 1
            elif cfg.objective == "balanced":
                weight = fastest.estimate["time"] / max(fastest.estimate["wear"], 1e-9)
                chosen = solve(problem, "balanced", work=cfg.work, seed=cfg.seed, time_limit=cfg.time_budget,
                               wear_weight=weight, start=previous)
                solves += 1
            rounds += 1
            solved = {id(a): a for a in [*answers.values(), chosen]}.values()
            changed = sum(self._plan_chosen_legs(problem, a, qs, stops) for a in solved)
            candidates += solved  # every leg of each is planned now: exactly evaluable
            bar.update(1)
            done = changed == 0 or rounds >= cfg.exact_rounds
            if done and rounds < EXTRA_ROUNDS * cfg.exact_rounds and not any(
                    all(self.leg(r, a, b, qs) is not None for r, route in enumerate(c.routes)
                        for a, b in zip([r, *route], [*route, r])) for c in candidates):
                done = False  # every answer so far lost a leg to a jam: solve again without it
            if done:
                break
        bar.close()
        problem = self.problem(task, options)
        pairs = RobotPairDistance(self.station)
        self._candidates = list(candidates)
        assignment, schedule, coordination = self._best(problem, candidates, task, options, qs, pairs, reference)
        improved = 0
        if cfg.objective in ("time", "wear") and cfg.pair_solves:
            # the best answer re-solved two robots at a time (CP-SAT searches a pair far better than the whole
            # station), each better answer judged coordinated; the last is the best
            kept = self._pair_improvements(task, options, qs, stops, assignment, schedule, coordination, pairs)
            if kept:
                improved = len(kept)
                candidates += kept
                self._candidates = list(candidates)
                problem = self.problem(task, options)
                assignment, schedule, coordination = self._best(problem, kept[-1:], task, options, qs, pairs,
                                                                reference)
        verification = verify(self.station, schedule, pairs=pairs)
        wear_bound = self._wear_bound(problem, straight, coordination["makespan_cap"]) \
            if cfg.objective == "wear" else None
        plan = StationPlan(task, [r.name for r in self.station.config.robots], options, assignment, schedule,
                           coordination, verification, self._bound(problem, straight, bound), cfg,
                           info={"rounds": rounds, "solves": solves, "nodes": len(qs), "pair_improvements": improved,
                                 "conflict_pairs": len(problem.conflicts), "candidates": len(candidates),
                                 "wear_solves_without_answer": wear_failures,
                                 "unconverged_cost_settles": self.unconverged_options(options),
                                 "cheapest_weld_wear": self.cheapest_weld_wear(task),
                                 "planned_legs": len(self._known), "cost_settles": len(self._rates),
                                 "simulated_legs": len(self._leg_runs),
                                 "unsettled_leg_starts": sum(not r.start_settled for r in self._leg_runs.values()),
                                 "rerouted_legs": list(self._reroute_log)},
                           wear_bound=wear_bound)
        return plan

    def _pair_improvements(self, task: StationTask, options: list[WeldOption], qs: np.ndarray, stops: list[str],
                           best: Assignment, schedule: StationSchedule, coordination: dict,
                           pairs: RobotPairDistance) -> list[Assignment]:
        """Better answers than ``best`` (the rounds' best, coordinated as ``schedule``), two robots re-solved at a
        time (station_solver.improve_by_pairs); each answer's legs are planned (and run with their cables) and
        the robots coordinated before it is judged. The wear objective keeps within ``coordination``'s cap."""
        cfg = self.config
        problem = self.problem(task, options)
        cap = coordination["makespan_cap"]
        if cfg.objective == "wear" and schedule.makespan > cap + 1e-9:
            return []  # no candidate within the cap: nothing to improve on
        verdicts = {}
        if cfg.objective == "time":
            verdicts[_routes_key(best.routes)] = (schedule.makespan, problem.evaluate(best.routes)["time"])
        else:
            verdicts[_routes_key(best.routes)] = (0.0, best.estimate["wear_with_waits"], schedule.makespan)

        def exact(routes):
            # the problem passed only times the estimates _plan_chosen_legs counts changes against (unused here)
            self._plan_chosen_legs(problem, Assignment(routes, {}, cfg.objective), qs, stops)
            return self.problem(task, options)

        def judge(p: RoutingProblem, routes) -> tuple:
            """An answer as the plan would be, coordinated: the solver's interlocks see two robots at one weld,
            not legs that cross (on side_framing_4r an answer of 27.4 s coordinated to 31.6 s)."""
            if _routes_key(routes) in verdicts:
                return verdicts[_routes_key(routes)]
            verdict = (np.inf,)
            estimate = p.evaluate(routes)
            if estimate["makespan"] < BLOCKED:
                best_time = min(v[0] for v in verdicts.values()) if cfg.objective == "time" else np.inf
                got = self._coordinated(p, routes, task, options, qs, pairs, cap=best_time)
                if got is not None and got[1]["resolved"]:
                    span, wear = got[0].makespan, got[2]
                    verdict = ((span, estimate["time"]) if cfg.objective == "time"
                               else (max(0.0, span - cap), wear, span))
            verdicts[_routes_key(routes)] = verdict
            return verdict

        bar = self._bar("re-solving the robots two at a time (improvements, at most)", PAIR_IMPROVEMENTS)
        problem, kept = improve_by_pairs(problem, best.routes, exact, judge, objective=cfg.objective,
                                         makespan_cap=cap if cfg.objective == "wear" else None, work=PAIR_WORK,
                                         solves=cfg.pair_solves, seed=cfg.seed, time_limit=cfg.time_budget,
                                         progress=bar)
        bar.close()
        return [Assignment(routes, problem.evaluate(routes), cfg.objective) for routes in kept]

    # -------------------------------------------------------------------------- the cables' verdict
    def jammed_legs(self, plan: StationPlan, qs: np.ndarray) -> list[tuple[int, int, int]]:
        """(robot, from node, to node) of the leg behind each jammed cable in ``plan.replay``: the motion under
        way when its tension first passed the jam strain, or, if the robot stood still then (welding, waiting),
        the motion that brought it there (the cable was wedged on the way and stays wedged). A robot without
        welds is left out: it never moves, so its cable was pinned by another robot."""
        replay = plan.replay
        out = []
        for r in replay.jammed():
            if not plan.assignment.routes[r]:  # a robot that stays Home has no leg to re-route (another pinned it)
                continue
            first = int(np.argmax(replay.measures["tension"][:, r] > replay.jam_tension[r]))
            t = float(replay.time[first])
            s = plan.schedule.robot(r)
            k = int(np.clip(np.searchsorted(s.leg_start, t, side="right") - 1, 0, len(s.legs) - 1))
            route = plan.assignment.routes[r]
            path = [r, *route, r]
            out.append((r, path[k], path[k + 1]))
        return out

    def _reroute(self, robot: int, i: int, j: int, qs: np.ndarray, stops: list[str], why: str,
                 weld_time: float) -> dict:
        """Replace the leg i -> j of ``robot`` after it jammed the cable: the next of :data:`REROUTES` that
        applies and does not jam the cable itself (run alone), else mark it blocked (the solver then avoids it).
        ``stops`` names every node (the summary's words); ``weld_time`` is the weld at j (0 at a Home). Returns
        what was done, also logged for the plan."""
        key = _leg_key(robot, qs[i], qs[j])
        old = self._rerouted.get(key, self._legs.get(key))
        done = "blocked"
        self._rerouted[key] = None
        for used, how in enumerate(REROUTES[self._reroutes.get(key, 0):], start=self._reroutes.get(key, 0) + 1):
            self._reroutes[key] = used
            leg = self._alternative(how, robot, qs[i], qs[j], old)
            if leg is not None and not self.leg_run(robot, leg, weld_time).jammed:
                self._rerouted[key], done = leg, how
                break
        entry = {"robot": self.station.config.robots[robot].name, "from": stops[i], "to": stops[j], "now": done,
                 "why": why}
        self._reroute_log.append(entry)
        return entry

    def _alternative(self, how: str, robot: int, qa: np.ndarray, qb: np.ndarray, old) -> np.ndarray | None:
        planner = self.leg_planners[robot]
        home = self.station.home[robot]
        if how == "reseeded":
            if old is not None and len(old) == 2:  # a straight move: any seed returns the same line
                return None
            seed, planner.seed = planner.seed, planner.seed + RESEED
            try:
                return plan_leg(planner, robot, qa, qb)
            finally:
                planner.seed = seed
        if np.array_equal(qa, home) or np.array_equal(qb, home):  # via_home: the leg already ends at Home
            return None
        if planner.validity.segment_valid(qa, home) and planner.validity.segment_valid(home, qb):
            return np.array([qa, home, qb])
        return None

    def replay(self, plan: StationPlan, record_every: float = RECORD_EVERY) -> StationReplay:
        bar = self._bar("station replay (simulated s)", round(plan.schedule.makespan + record_every, 2))
        last = [0.0]

        def tick(t):
            bar.update(round(t - last[0], 3))
            last[0] = t

        sim = CableSimulator(self.station)
        plan.replay = replay_station(sim, plan.schedule, record_every=record_every,
                                     cost_variant=self.config.cost_variant, on_sample=tick)
        bar.close()
        return plan.replay

    def _bar(self, label: str, total):
        if self.progress is None:
            return _NoBar()
        return self.progress(label, total)


def _routes_key(routes) -> tuple:
    return tuple(map(tuple, routes))


def _task_key(task: StationTask) -> tuple:
    """What a station task is, as a dictionary key: its welds, weld time, Homes and every option."""
    return (task.weld_names, float(task.weld_time), np.asarray(task.homes, dtype=float).tobytes(),
            tuple((o.weld, int(o.robot), np.asarray(o.q, dtype=float).tobytes())
                  for w in task.weld_names for o in task.options[w]))


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass


def save_plan(plan: StationPlan, out: Path) -> None:
    """plan.json (summary, per-robot timing) and one trajectory .npz per robot under ``out``."""
    from dresspack_gym.physics.trajectory import save_trajectory

    out.mkdir(parents=True, exist_ok=True)
    robots = {}
    for s in plan.schedule.robots:
        name = plan.names[s.robot]
        # the .npz holds the waypoints (a single-robot trajectory, stopping at each: what `dresspack export` writes);
        # which legs fly by their via points is in its meta and plan.json
        save_trajectory(out / f"{name}.npz", s.trajectory(), robot=s.robot, robot_name=name,
                        leg_start=s.leg_start.tolist(), weld_time=s.weld_time, fly_by=list(s.fly_by))
        robots[name] = {"welds": list(s.welds), "leg_start": s.leg_start.round(4).tolist(), "fly_by": list(s.fly_by),
                        "waits": s.waits().round(4).tolist(), "end_time": round(s.end_time, 4),
                        "trajectory": f"{name}.npz"}
    data = {"summary": plan.summary(), "robots": robots, "config": asdict(plan.config)}
    (out / "plan.json").write_text(json.dumps(data, indent=1, default=_json_default))


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x)}")
