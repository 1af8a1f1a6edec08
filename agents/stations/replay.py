"""Replaying a station plan in the cable simulator (on the plan's engine), every robot on one clock, with a progress
bar."""

from __future__ import annotations

from dresspack_gym.multi.replay import StationReplay, replay_station
from dresspack_gym.physics.profiles import make_simulator
from dresspack_gym.stations.station import Station

from .config import RECORD_EVERY
from .plan import StationPlan


def replay_plan(station: Station, plan: StationPlan, cost_variant: str, bar, record_every: float = RECORD_EVERY,
                engine: str = "dynamic") -> StationReplay:
    """``plan`` run in the cable simulator on ``engine`` (physics.profiles.ENGINES; its cables' verdict), kept as
    ``plan.replay``; ``bar(label, total)`` a progress bar factory (simulated seconds). The rod engine (fast) has no
    contact between two robots' cables: its replay cannot see a cable caught on another robot's cable."""
    bar = bar("station replay (simulated s)", round(plan.schedule.makespan + record_every, 2))
    last = [0.0]

    def tick(t):
        bar.update(round(t - last[0], 3))
        last[0] = t

    sim = make_simulator(station, engine)
    plan.replay = replay_station(sim, plan.schedule, record_every=record_every, cost_variant=cost_variant,
                                 on_sample=tick)
    bar.close()
    return plan.replay
