"""Replaying a station plan in the cable simulator, every robot on one clock, with a progress bar."""

from __future__ import annotations

from dresspack_gym.multi.replay import StationReplay, replay_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station

from .config import RECORD_EVERY
from .plan import StationPlan


def replay_plan(station: Station, plan: StationPlan, cost_variant: str, bar,
                record_every: float = RECORD_EVERY) -> StationReplay:
    """``plan`` run in the cable simulator (its cables' verdict), kept as ``plan.replay``; ``bar(label, total)`` a
    progress bar factory (simulated seconds)."""
    bar = bar("station replay (simulated s)", round(plan.schedule.makespan + record_every, 2))
    last = [0.0]

    def tick(t):
        bar.update(round(t - last[0], 3))
        last[0] = t

    sim = CableSimulator(station)
    plan.replay = replay_station(sim, plan.schedule, record_every=record_every, cost_variant=cost_variant,
                                 on_sample=tick)
    bar.close()
    return plan.replay
