"""Global wear-aware planner: candidate routes of different classes (the wear map's roadmap routes, and OMPL
routes through random via configurations), each scored by simulating the cable along it in path order; the
best is refined locally. Unlike the thesis's local optimiser it can switch to another route class (e.g. under
an obstacle instead of over it)."""

from __future__ import annotations

from dresspack_gym.maps.map_cost import MapStateCost
from dresspack_gym.maps.wear_map import WearMap, load_wear_map
from dresspack_gym.physics.profiles import DEFAULT_ENGINE

from .composed import ComposedPlanner
from .fmt_routes import FMT_SAMPLES, FMT_WEIGHTS, FmtSearch
from .leg_cost import TENSION_PEAK_TIME, LegCost, check_tension_peak_time
from .map_roadmap import MapRoadmap
from .map_routes import ROADMAP_WEIGHTS, MapRoutes
from .refine import LocalRefiner
from .routes import ViaRoutes


class OmplWearPlanner(ComposedPlanner):
    """``routes`` (the budget's) candidate routes per leg, each scored by one cable simulation; the best refined.
    The score is the leg's seconds + ∫C dt + ``tension_peak_time`` x its peak tension term (see LegCost).

    ``wear_map``: a map file (default: the shipped map of this robot and dresspack, if there is one; False:
    none); with it the candidates start with the map's roadmap routes, without it they are via routes only
    (``info["wear_map"]`` says which)."""

    name = "ompl-wear"
    color = "#e7298a"

    weights = ROADMAP_WEIGHTS  # time/wear trade-offs of the global searches over the map, one route each

    def __init__(self, *args, via_spread_deg: float = 90.0, n_interior: int = 3,
                 step_deg: float = 15.0, time_weight: float = 1.0, wear_weight: float = 1.0,
                 tension_peak_time: float = TENSION_PEAK_TIME, cost_variant: str = "thesis",
                 wear_map: str | WearMap | bool | None = None, engine: str = DEFAULT_ENGINE, jobs: int = 1,
                 **kwargs):
        tension_peak_time = check_tension_peak_time(tension_peak_time)  # before the roadmap is built
        super().__init__(*args, **kwargs)
        via = ViaRoutes(self.connector, self.validity, self.budget.iterations, self.budget.routes, via_spread_deg)
        if wear_map is False:
            self.wear_map = None
        elif isinstance(wear_map, WearMap):
            self.wear_map = wear_map
        else:
            self.wear_map = load_wear_map(self.station.config, self.robot, wear_map)
        search = None
        if self.wear_map is not None:
            search = self._global_search(MapStateCost(self.station, self.wear_map, self.robot, cost_variant))
        self.routes = MapRoutes(via, search, self.budget.routes, self.weights)
        self.leg_cost = LegCost(self.station, self.robot, time_weight=time_weight, wear_weight=wear_weight,
                                tension_peak_time=tension_peak_time, cost_variant=cost_variant, engine=engine,
                                jobs=jobs)
        self.refiner = LocalRefiner(self.validity, self.leg_cost, n_interior, step_deg)

    def _global_search(self, cost: MapStateCost):
        """The search over the map: a lazy PRM* on the map's own configurations, built once and reused by every
        leg and plan (it depends on no seed)."""
        return MapRoadmap(self.wear_map, self.validity, cost, self.motion_limits)

    def _reseed(self) -> None:
        super()._reseed()
        if self.routes.roadmap is not None:
            self.routes.roadmap.forget()

    def _plan(self, task):
        traj, info = super()._plan(task)
        info["wear_map"] = self.wear_map.info["key"] if self.wear_map is not None else None
        info["tension_peak_time"] = self.leg_cost.tension_peak_time
        if self.routes.roadmap is not None:
            info.update(self._search_info(self.routes.roadmap))
        return traj, info

    @staticmethod
    def _search_info(roadmap: MapRoadmap) -> dict:
        return {"roadmap_milestones": len(roadmap.nodes)}


class OmplFmtWearPlanner(OmplWearPlanner):
    """``ompl-wear`` with OMPL's asymptotically optimal FMT* as the global search over the wear map (the state-cost
    integral of time plus weighted wear, ``fmt_samples`` samples per search, the work unit) in place of the lazy
    PRM* on the map's own configurations; the same direct, via and refined routes, ranked by the same cable
    simulation. Without a wear map it is ``ompl-wear`` without one."""

    name = "ompl-wear-fmt"
    color = "#66a61e"
    weights = FMT_WEIGHTS

    def __init__(self, *args, fmt_samples: int = FMT_SAMPLES, fmt_radius_multiplier: float = 1.0, **kwargs):
        self.fmt_samples, self.fmt_radius_multiplier = fmt_samples, fmt_radius_multiplier
        super().__init__(*args, **kwargs)

    def _global_search(self, cost: MapStateCost):
        return FmtSearch(self.validity, cost, self.motion_limits, samples=self.fmt_samples,
                         radius_multiplier=self.fmt_radius_multiplier)

    @staticmethod
    def _search_info(search: FmtSearch) -> dict:
        return {"fmt_samples": search.samples, "fmt_motion_checks": search.motion_checks}
