"""Thesis-style wear-aware planner: a nominal (wear-unaware) path, then local optimisation of its waypoints
with the cost time + (4.10), legs optimised in path order so the cable state carries over (thesis §5.3)."""

from __future__ import annotations

from .composed import ComposedPlanner
from .leg_cost import LegCost
from .refine import LocalRefiner
from .routes import DirectRoute


class ThesisLocalPlanner(ComposedPlanner):
    """Nominal path from OMPL (no cable), then stochastic local search on each leg's interior waypoints."""

    name = "thesis-local"
    color = "#7570b3"

    def __init__(self, *args, n_interior: int = 3, step_deg: float = 15.0, time_weight: float = 1.0,
                 wear_weight: float = 1.0, cost_variant: str = "thesis", **kwargs):
        super().__init__(*args, **kwargs)
        self.routes = DirectRoute(self.connector, self.budget.iterations)
        self.leg_cost = LegCost(self.station, self.robot, time_weight=time_weight, wear_weight=wear_weight,
                                cost_variant=cost_variant)
        self.refiner = LocalRefiner(self.validity, self.leg_cost, n_interior, step_deg)
