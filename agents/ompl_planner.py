"""Wear-unaware baseline: OMPL RRTConnect + path simplification per leg (today's practice, no cable)."""

from __future__ import annotations

from .composed import ComposedPlanner
from .routes import DirectRoute


class OmplPlanner(ComposedPlanner):
    """Joint-space RRTConnect with limits + joint restrictions + collision as validity; shortest-time leg."""

    name = "ompl"
    color = "#d95f02"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.routes = DirectRoute(self.connector, self.budget.iterations)
