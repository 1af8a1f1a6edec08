"""The settings of a station plan (StationPlanConfig), and the constants and the silent progress bar its planning
jobs share."""

from __future__ import annotations

from dataclasses import dataclass

from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import check_choice, check_integer, check_number
from dresspack_gym.multi.tasks import DEFAULT_WELD_TIME
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, ENGINES
from dresspack_gym.physics.wear_cost import cost_function

from ..planners.budget import DEFAULT_ITERATIONS
from ..planners.composed import OmplPlanner
from .fast_routes import FastLegPlanner
from .solver import BLOCKED_ESTIMATES, BOUND_WORK, DEFAULT_WORK, LEG_ROUTES, MAKESPAN_SLACK, OBJECTIVES, PAIR_SOLVES

# rounds allowed, as a multiple of exact_rounds, while no solved answer has every leg planned (legs that jam their
# cable are blocked as they are found, so an answer can lose a leg after it was chosen)
EXTRA_ROUNDS = 3
# [s] sampling of the wear cost C along a simulated leg and in the station replay (the integral is over these
# samples; one value for both, so a leg's simulated wear and its part of the replay are the same measure)
RECORD_EVERY = 0.05
# how a leg whose straight move is blocked is planned (StationPlanConfig.leg_route): "fastest", the straight move
# else one taught via point else OMPL, shortened under the time law (stations/fast_routes.py); "ompl", OMPL's
# RRTConnect path as the single-robot ``ompl`` planner returns it (on side_framing_4r its detours took 1.6x as long)
LEG_PLANNERS = dict(zip(LEG_ROUTES, (FastLegPlanner, OmplPlanner)))


@dataclass(frozen=True)
class StationPlanConfig:
    """Settings of a station plan (defaults: what ``dresspack station-plan`` uses)."""

    objective: str = "time"
    weld_time: float = DEFAULT_WELD_TIME
    work: float = DEFAULT_WORK  # solver work budget per solve (CP-SAT deterministic seconds)
    time_budget: float | None = None  # optional wall-clock cap per solve [s]
    costed_options: int = 8  # per weld and robot: IK options (nearest Home first) whose settled cable is costed
    # per weld and robot: options the solver chooses from (half nearest Home, half cheapest); at most costed_options
    kept_options: int = 2
    iterations: int = DEFAULT_ITERATIONS  # OMPL iterations per leg
    # solve -> plan chosen legs -> re-solve rounds; more (up to EXTRA_ROUNDS x) while no answer has every leg planned
    exact_rounds: int = 2
    # then solves of two robots at a time (solver.improve_by_pairs; 0: none), each better answer coordinated
    pair_solves: int = PAIR_SOLVES
    # CP-SAT deterministic seconds proving the makespan bound (solver.relaxation_bound); it changes only the bound,
    # never the plan
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
    # like a path: stations/fast_routes.curve_valid), else stop at each; False: every leg stops at each
    fly_by: bool = True
    # the wear and balanced objectives: every robot's moves between its Home and options planned before the rounds
    # (LegBook.plan_every_move), so their solver times every move exactly and chooses
    # among legs it knows (side_framing_4r's wear plan: 3,852 against 4,021). The time objective plans its legs
    # lazily whatever this says: with every move exact its answers packed the robots tighter than coordination could
    # keep (36.1 s against 24.7 s)
    legs_up_front: bool = False
    # the cable engine of every simulation of the plan: option costs, leg runs, the station replay and its jams
    # (physics.profiles.ENGINES; the rod engine has no contact between two robots' cables)
    physics: str = DEFAULT_ENGINE
    # processes settling the options' cables, checking straight moves, planning legs and running them with their
    # cables (1: in this process). A plan does not depend on it: each of those results depends only on its inputs
    jobs: int = 1

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
        if self.kept_options > self.costed_options:  # the solver's options are chosen among the costed ones
            raise ConfigError("kept_options", f"{self.kept_options} is more than costed_options "
                                              f"({self.costed_options}): the options kept are chosen among those "
                                              f"costed; allowed: 1 to {self.costed_options}")
        check_integer(self.exact_rounds, "exact_rounds", lo=1, hi=100)
        check_integer(self.pair_solves, "pair_solves", lo=0, hi=10_000)
        check_number(self.bound_work, "bound_work", lo=0.0, lo_open=True, hi=1e6)
        check_integer(self.cable_repairs, "cable_repairs", lo=0, hi=100)
        check_choice("physics", self.physics, ENGINES)
        check_integer(self.jobs, "jobs", lo=1, hi=64)
        check_number(self.makespan_slack, "makespan_slack", lo=0.0, hi=10.0)
        check_integer(self.seed, "seed", lo=0, hi=2 ** 32 - 1)
        cost_function(self.cost_variant)


def no_bar(label: str, total) -> _NoBar:
    """A progress bar factory that shows nothing (the jobs' default)."""
    return _NoBar()


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass
