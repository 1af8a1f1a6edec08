"""A station schedule run in the cable simulator on one clock: every robot's cable, measured over the cycle.

Robots move, weld and wait together, so cables meet the other robots (and their cables) where the schedule
brings them close; welding and waiting are time on the clock in which the cable hangs and is costed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics.simulation import CableSimulator, Equilibrium
from ..physics.wear_cost import cost_function
from .schedule import PHASES, StationSchedule

# A cable whose tension exceeds this strain x EA is flagged jammed: no copper conductor survives 5 % strain, so
# such a state is a cable pinned by a robot (kinematic, unstoppable), not a wear figure to compare
JAM_STRAIN = 0.05

MEASURE_FIELDS = {"curvature": "max_curvature", "tension": "max_tension", "clearance": "min_clearance",
                  "twist_rate": "max_twist_rate"}


@dataclass
class StationReplay:
    """Per robot: measures and the wear cost C(t) sampled on the station clock [s]."""

    time: np.ndarray  # (N,)
    measures: dict[str, np.ndarray]  # MEASURE_FIELDS -> (N, n_robots)
    cost: np.ndarray  # (N, n_robots)
    makespan: float
    jam_tension: np.ndarray | None = None  # (n_robots,) [N] tension above which a cable is flagged jammed
    start: Equilibrium | None = None  # the settle at Home the cycle starts from (its residual)
    terms: dict[str, np.ndarray] | None = None  # the cost's terms (WearCost.terms) -> (N, n_robots); sum = cost
    engine: str = "dynamic"  # the cable engine that produced the measures (physics.profiles.ENGINES)

    def jammed(self) -> list[int]:
        """Robots whose cable was ever pulled beyond JAM_STRAIN (pinned by a robot)."""
        if self.jam_tension is None:
            return []
        return [int(i) for i in np.flatnonzero(self.measures["tension"].max(axis=0) > self.jam_tension)]

    def integrated_cost(self) -> np.ndarray:
        """Per robot, the integral of C over the cycle [cost x s]."""
        return np.trapezoid(self.cost, self.time, axis=0) if len(self.time) > 1 else np.zeros(self.cost.shape[1])

    def running_cost(self) -> np.ndarray:
        """(N, n_robots): the trapezoid integral of C from the cycle's start to each sample (its last row is
        :meth:`integrated_cost`)."""
        pieces = 0.5 * (self.cost[1:] + self.cost[:-1]) * np.diff(self.time)[:, None]
        return np.concatenate([np.zeros((1, self.cost.shape[1])), np.cumsum(pieces, axis=0)])

    def wear_split(self, schedule: StationSchedule) -> dict:
        """Per robot index, the integrated cost split by what the robot did (``by_phase``: :data:`PHASES`, from
        ``schedule``) and by the cost's terms (``by_term``, when recorded). Each sampling interval counts whole
        to the phase at its midpoint, so either split sums to :meth:`integrated_cost` (the same trapezoids)."""
        dt = np.diff(self.time)
        mid = self.time[:-1] + dt / 2

        def pieces(c):  # (N-1, n_robots): each interval's trapezoid
            return 0.5 * (c[1:] + c[:-1]) * dt[:, None]

        cost = pieces(self.cost)
        terms = {k: pieces(v).sum(axis=0) for k, v in (self.terms or {}).items()}
        out = {}
        for i in range(self.cost.shape[1]):
            s = schedule.robot(i)
            phase = s.phase_at(mid) if s is not None else np.full(len(mid), PHASES.index("done"))
            out[i] = {"by_phase": {p: float(cost[phase == k, i].sum()) for k, p in enumerate(PHASES)},
                      "by_term": {k: float(v[i]) for k, v in terms.items()}}
        return out

    def summary(self, names: list[str]) -> dict:
        per = self.integrated_cost()
        return {
            "engine": self.engine,
            "makespan": round(self.makespan, 3),
            "cost": float(per.sum()),
            "jammed": [names[i] for i in self.jammed()],
            **({"start_settled": self.start.converged, "start_force_residual": self.start.force_residual}
               if self.start is not None else {}),
            "robots": {n: {"cost": float(per[i]),
                           "max_curvature": float(self.measures["curvature"][:, i].max()),
                           "max_tension": float(self.measures["tension"][:, i].max()),
                           "min_clearance": float(self.measures["clearance"][:, i].min()),
                           "max_twist_rate": float(self.measures["twist_rate"][:, i].max())}
                       for i, n in enumerate(names)},
        }


def replay_station(sim: CableSimulator, schedule: StationSchedule, *, record_every: float = 0.05,
                   cost_variant: str = "thesis", on_sample=None) -> StationReplay:
    """Settle the cables with every robot at Home, then run ``schedule`` to its makespan."""
    cost_fn = cost_function(cost_variant)
    cfg = sim.station.config.wear_cost
    sim.reset(schedule.homes)
    start = sim.last_settle.equilibrium
    sim.motion_time = 0.0
    times, samples = [0.0], [sim.cable_measures()]
    t, s = sim.follow(schedule.at, schedule.makespan, record_every=record_every, on_sample=on_sample)
    times += t
    samples += s
    measures = {k: np.array([[getattr(m, f) for m in per] for per in samples]) for k, f in MEASURE_FIELDS.items()}
    costs = [[cost_fn(m, cfg) for m in per] for per in samples]
    cost = np.array([[c.total for c in per] for per in costs])
    by_term = [[c.terms() for c in per] for per in costs]
    terms = {k: np.array([[t[k] for t in per] for per in by_term]) for k in by_term[0][0]}
    jam = np.array([JAM_STRAIN * r.dresspack.tensile_stiffness for r in sim.station.config.robots])
    return StationReplay(np.array(times), measures, cost, schedule.makespan, jam, start, terms, sim.engine)
