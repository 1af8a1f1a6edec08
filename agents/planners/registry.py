"""The planner registry, and planning a station's task with a named planner measured by replaying it (shared
by CLI and eval). A new planner is one module plus one line in ``PLANNERS``."""

from __future__ import annotations

from dataclasses import dataclass

from dresspack_gym.fields import check_choice
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, ENGINES, make_simulator
from dresspack_gym.physics.trajectory import Replay, replay
from dresspack_gym.physics.wear_cost import cost_function
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task, make_task

from ..learned.policy import PolicyPlanner, RandomMaskedPlanner
from ..learned.search import PolicySearchPlanner
from .base import Planner, PlanResult
from .budget import DEFAULT_EVALUATIONS, DEFAULT_ITERATIONS, DEFAULT_ROUTES
from .composed import OmplPlanner, ThesisLocalPlanner
from .wear_global import OmplFmtWearPlanner, OmplWearPlanner

PLANNERS: dict[str, type[Planner]] = {p.name: p for p in (
    PolicyPlanner,
    PolicySearchPlanner,
    OmplPlanner,
    ThesisLocalPlanner,
    OmplWearPlanner,
    OmplFmtWearPlanner,
    RandomMaskedPlanner,
)}
POLICY_METHODS = tuple(name for name, p in PLANNERS.items() if p.uses_policy)
# the planners that take a cost_variant and a time_weight (ppo-search: for its other routes and refinement)
WEAR_AWARE = (ThesisLocalPlanner.name, OmplWearPlanner.name, OmplFmtWearPlanner.name, PolicySearchPlanner.name)
# the planners that also charge a leg's peak tension (``tension_peak_time``); thesis-local keeps (4.10) alone
PEAK_AWARE = (OmplWearPlanner.name, OmplFmtWearPlanner.name)
COLORS = {name: p.color for name, p in PLANNERS.items()}


def make_planner(name: str, station: Station, robot: int = 0, **kwargs) -> Planner:
    check_choice("planner", name, PLANNERS)
    return PLANNERS[name](station, robot, **kwargs)


@dataclass
class PlannedRun:
    task: Task
    plan: PlanResult
    replay: Replay
    station: Station | None = None

    def summary(self) -> dict:
        s = {"method": self.plan.method, "success": True, "planning_time": round(self.plan.planning_time, 3),
             "welds": list(self.task.weld_names), "waypoints": len(self.plan.trajectory.waypoints)}
        s.update(self.replay.summary())
        s["planner_info"] = self.plan.info
        return s


def plan_station(station_ref: str | Station, planner: str = "ompl", *, robot: int = 0, seed: int = 0,
                 iterations: int = DEFAULT_ITERATIONS, evaluations: int = DEFAULT_EVALUATIONS,
                 routes: int = DEFAULT_ROUTES, time_budget: float | None = None, welds: list[str] | None = None,
                 task: Task | None = None, cost_variant: str = "thesis", physics: str = DEFAULT_ENGINE,
                 jobs: int = 1, **planner_kwargs) -> PlannedRun:
    """Plan ``task`` (default: Home -> ``welds`` -> Home) and replay it; ``planner_kwargs`` go to the planner
    (e.g. ``policy=`` for ``ppo``). The budget is ``iterations`` / ``evaluations`` / ``routes`` (work units, see
    :class:`~dresspack.agents.planners.budget.Budget`), with ``time_budget`` [s] as an optional wall-time cap.
    ``cost_variant`` is the wear cost the wear-aware planners minimise and the replay reports (thesis, normalized,
    damage, life). ``physics`` (physics.profiles.ENGINES) is the cable engine the wear-aware planners simulate
    legs on and the plan is replayed in; they simulate legs on ``jobs`` processes (the plan does not depend on it)."""
    cost_function(cost_variant)  # a bad name fails before planning, naming the field
    check_choice("physics", physics, list(ENGINES))
    station = station_ref if isinstance(station_ref, Station) else Station(load_station(station_ref))
    if planner in WEAR_AWARE:
        planner_kwargs = {"cost_variant": cost_variant, "engine": physics, "jobs": jobs, **planner_kwargs}
    p = make_planner(planner, station, robot, seed=seed, iterations=iterations, evaluations=evaluations,
                     routes=routes, time_budget=time_budget, **planner_kwargs)
    if task is None:
        task = make_task(station, robot, p.validity.checker.collides, welds)
    result = p.plan(task)
    rep = replay(make_simulator(station, physics), result.trajectory, robot=robot, cost_variant=cost_variant)
    return PlannedRun(task, result, rep, station)
