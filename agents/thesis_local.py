"""Thesis-style wear-aware planner: a nominal (wear-unaware) path, then local optimisation of its waypoints
with the cost time + (4.10), legs optimised in path order so the cable state carries over (thesis §5.3)."""

from __future__ import annotations

import time

import numpy as np

from dresspack_gym.tasks import Task
from dresspack_gym.trajectory import Trajectory

from .leg_cost import LegCost
from .ompl_planner import OmplPlanner


def densify(leg: np.ndarray, n_interior: int) -> np.ndarray:
    """Add interior waypoints on the leg's segments (at least ``n_interior`` in all) to give the optimiser
    handles; long segments get more."""
    seg = np.linalg.norm(np.diff(leg, axis=0), axis=1)
    extra = max(0, n_interior - (len(leg) - 2))
    if extra == 0 or seg.sum() == 0:
        return leg
    share = np.floor(extra * seg / seg.sum()).astype(int)
    share[np.argsort(-seg)[: extra - share.sum()]] += 1
    pts = [leg[0]]
    for a, b, k in zip(leg[:-1], leg[1:], share):
        pts.extend(a + (b - a) * t for t in np.linspace(0, 1, k + 2)[1:])
    return np.array(pts)


class ThesisLocalPlanner(OmplPlanner):
    """Nominal path from OMPL (no cable), then stochastic local search on each leg's interior waypoints."""

    name = "thesis-local"

    def __init__(self, *args, n_interior: int = 3, step_deg: float = 15.0, time_weight: float = 1.0,
                 wear_weight: float = 1.0, cost_variant: str = "thesis", nominal_share: float = 0.25, **kwargs):
        super().__init__(*args, **kwargs)
        self.n_interior = n_interior
        self.step = np.radians(step_deg)
        self.nominal_share = nominal_share
        self.leg_cost = LegCost(self.station, self.robot, time_weight=time_weight, wear_weight=wear_weight,
                                cost_variant=cost_variant)
        self.rng = np.random.default_rng(self.seed)

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        self._nominal = self.connect_stops(task, self.time_budget * self.nominal_share)
        return self._optimise_legs(task, {"nominal_waypoints": sum(len(g) - 1 for g in self._nominal) + 1})

    def _start_leg(self, k: int, state: np.ndarray, a: np.ndarray, b: np.ndarray,
                   until: float) -> tuple[np.ndarray, float]:
        """The leg the local search starts from, and the objective of the wear-unaware route (for the report)."""
        leg = self._nominal[k]
        return leg, self.leg_cost.cost(state, leg)[0]

    def _optimise_legs(self, task: Task, info: dict) -> tuple[Trajectory, dict]:
        """Legs in path order, each from the cable state the previous ones left; the time left is shared out."""
        stops = task.waypoints()
        n = len(stops) - 1
        state = self.leg_cost.start_state(task.start)
        out, before, after = [], 0.0, 0.0
        for k, (a, b) in enumerate(zip(stops[:-1], stops[1:])):
            leg_end = self.deadline - self.remaining() * (1 - 1 / (n - k))
            start, j0 = self._start_leg(k, state, a, b, leg_end)
            best = self.improve(state, start, leg_end)
            j, state, _ = self.leg_cost.cost(state, best)
            out.append(best)
            before, after = before + j0, after + j
        info.update({"objective_nominal": before, "objective": after,
                     "cable_evaluations": self.leg_cost.evaluations})
        return Trajectory.from_legs(out), info

    def improve(self, state: np.ndarray, leg: np.ndarray, until: float) -> np.ndarray:
        """Random-perturbation hill climbing on the interior waypoints of one leg (ends fixed) until ``until``
        (perf_counter time); the step shrinks when a sweep finds nothing."""
        best = leg.copy()
        j_best = self.leg_cost.cost(state, best)[0]
        cand = densify(best, self.n_interior)
        if len(cand) > len(best) and self._leg_valid(cand):
            best, j_best = cand, self.leg_cost.cost(state, cand)[0]
        step = self.step
        while time.perf_counter() < until and step > np.radians(1.0):
            improved = False
            for i in self.rng.permutation(np.arange(1, len(best) - 1)):
                if time.perf_counter() >= until:
                    break
                trial = best.copy()
                trial[i] = best[i] + self.rng.normal(0.0, step, 6)
                if not self._leg_valid(trial, around=i):
                    continue
                j = self.leg_cost.cost(state, trial)[0]
                if j < j_best:
                    best, j_best, improved = trial, j, True
            if not improved:
                step *= 0.6
        return self._drop_useless(state, best, j_best)

    def _drop_useless(self, state, leg, j_best):
        """Remove interior waypoints that do not pay for their stop (time) — keeps trajectories lean."""
        i = 1
        while i < len(leg) - 1:
            trial = np.delete(leg, i, axis=0)
            if self._leg_valid(trial, around=i - 1) and self.leg_cost.cost(state, trial)[0] <= j_best:
                leg, j_best = trial, self.leg_cost.cost(state, trial)[0]
            else:
                i += 1
        return leg

    def _leg_valid(self, leg: np.ndarray, around: int | None = None) -> bool:
        """All segments, or only the two touching waypoint ``around`` (a segment check covers its end points)."""
        ks = range(len(leg) - 1) if around is None else range(max(0, around - 1), min(len(leg) - 1, around + 1))
        return all(self.validity.segment_valid(leg[k], leg[k + 1]) for k in ks)
