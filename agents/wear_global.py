"""Global wear-aware planner: explores different route classes with OMPL (via random intermediate
configurations), scores every candidate route by simulating the cable along it in path order, keeps the
best and refines it locally. Unlike the thesis's local optimiser it can switch to another route class
(e.g. under an obstacle instead of over it)."""

from __future__ import annotations

from .composed import ComposedPlanner
from .leg_cost import LegCost
from .refine import LocalRefiner
from .routes import ViaRoutes


class OmplWearPlanner(ComposedPlanner):
    """``routes`` (the budget's) candidate routes per leg, each scored by one cable simulation; the best refined."""

    name = "ompl-wear"
    color = "#e7298a"

    def __init__(self, *args, via_spread_deg: float = 90.0, n_interior: int = 3,
                 step_deg: float = 15.0, time_weight: float = 1.0, wear_weight: float = 1.0,
                 cost_variant: str = "thesis", **kwargs):
        super().__init__(*args, **kwargs)
        self.routes = ViaRoutes(self.connector, self.validity, self.budget.iterations, self.budget.routes,
                                via_spread_deg)
        self.leg_cost = LegCost(self.station, self.robot, time_weight=time_weight, wear_weight=wear_weight,
                                cost_variant=cost_variant)
        self.refiner = LocalRefiner(self.validity, self.leg_cost, n_interior, step_deg)
