"""A planner assembled from parts: a route generator, optionally a leg cost and a refiner (legs in path order); the
two planners of direct routes: the wear-unaware OMPL baseline and the thesis's local wear-aware planner."""

from __future__ import annotations

import math

import numpy as np

from dresspack_gym.physics.profiles import DEFAULT_ENGINE
from dresspack_gym.physics.trajectory import Trajectory
from dresspack_gym.stations.tasks import Task

from .base import Planner
from .leg_cost import LegCost
from .ompl_connect import OmplConnector
from .refine import LocalRefiner, leg_share
from .routes import DirectRoute


class ComposedPlanner(Planner):
    """Per leg, in path order: the route generator's candidates; with a leg cost, the cheapest one (scored by
    simulating the cable from the state the previous legs left), then the refiner's improvement of it. The
    refinement budget (``evaluations`` leg-cost queries) is shared out over the legs still to plan.

    Subclasses only choose the parts (``routes``, ``leg_cost``, ``refiner``) in their constructor."""

    def __init__(self, station, robot: int = 0, *, simplify: bool = True, **kwargs):
        super().__init__(station, robot, **kwargs)
        self.connector = OmplConnector(self.validity, self.name, simplify)
        self.routes = None  # a route generator: candidates(a, b, rng, allowance) -> [legs]
        self.leg_cost: LegCost | None = None
        self.refiner: LocalRefiner | None = None
        self._refine_queries = 0  # leg-cost queries the refiner used in this plan

    def _reseed(self) -> None:
        super()._reseed()
        self.connector.reseed(self.seed)
        self._refine_queries = 0
        if self.leg_cost is not None:
            self.leg_cost.reset()

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        stops = task.waypoints()
        n = len(stops) - 1
        cost = self.leg_cost
        state = cost.start_state(task.start) if cost is not None else None
        legs, explored, before, after, route_scores = [], 0, 0.0, 0.0, []
        for k, (a, b) in enumerate(zip(stops[:-1], stops[1:])):
            cands = self.routes.candidates(a, b, self.rng, self.allowance)
            explored += len(cands)
            if cost is None:
                legs.append(cands[0])
                continue
            scores = []  # a candidate dearer than the cheapest before it scores inf: its simulation stopped there
            for i, c in enumerate(cands):
                if i % cost.jobs == 0:  # the next jobs candidates on the workers, bounded as the first of them is
                    cost.prefetch(state, cands[i:i + cost.jobs], min(scores, default=math.inf))
                scores.append(cost.cost(state, c, min(scores, default=math.inf))[0])
            route_scores.append([float(x) if math.isfinite(x) else None for x in scores])
            best = cands[int(np.argmin(scores))]
            if self.refiner is not None:
                share = leg_share(self.budget.evaluations, self._refine_queries, n - k)
                q0 = cost.queries
                best = self.refiner.improve(state, best, share, self.rng, self.allowance)
                self._refine_queries += cost.queries - q0
            j, state, _ = cost.cost(state, best)
            legs.append(best)
            before, after = before + scores[0], after + j
        traj = Trajectory.from_legs(legs)
        info = {"duration": self.duration(traj), "waypoints": len(traj.waypoints), "routes_explored": explored,
                "ompl_iterations": self.connector.iterations_used,
                # the wall cap (off by default) cut the search short: the answer is the best route found by then,
                # at worst the first candidate (the wear-unaware route), never nothing
                "wall_cap_reached": self.allowance.out_of_time()}
        if cost is not None:
            info.update(engine=cost.sim.engine, objective_nominal=before, objective=after,
                        cable_evaluations=cost.evaluations,
                        # per leg, each candidate route's leg cost before refinement (None: dearer than one before it)
                        route_scores=route_scores, cable_simulations_given_up=cost.given_up)
        return traj, info


class OmplPlanner(ComposedPlanner):
    """Wear-unaware baseline (today's practice, no cable): joint-space RRTConnect with limits + joint restrictions
    + collision as validity, and path simplification per leg; shortest-time leg."""

    name = "ompl"
    color = "#d95f02"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.routes = DirectRoute(self.connector, self.budget.iterations)


class ThesisLocalPlanner(ComposedPlanner):
    """Thesis-style wear-aware planner (thesis §5.3): a nominal path from OMPL (no cable), then stochastic local
    search on each leg's interior waypoints with the cost time + (4.10), legs optimised in path order so the cable
    state carries over."""

    name = "thesis-local"
    color = "#7570b3"

    def __init__(self, *args, n_interior: int = 3, step_deg: float = 15.0, time_weight: float = 1.0,
                 wear_weight: float = 1.0, cost_variant: str = "thesis", engine: str = DEFAULT_ENGINE,
                 jobs: int = 1, **kwargs):
        super().__init__(*args, **kwargs)
        self.routes = DirectRoute(self.connector, self.budget.iterations)
        self.leg_cost = LegCost(self.station, self.robot, time_weight=time_weight, wear_weight=wear_weight,
                                cost_variant=cost_variant, engine=engine, jobs=jobs)
        self.refiner = LocalRefiner(self.validity, self.leg_cost, n_interior, step_deg)
