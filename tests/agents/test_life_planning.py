"""Planning for life on the demo's first task with the calibrated dresspack: ompl-wear with --cost-variant life plans
a cycle whose cable lives longer than ompl's (the wear-unaware planner's) by the same fatigue model."""

from dataclasses import replace
from pathlib import Path

import pytest

pytest.importorskip("ompl")

from dresspack.agents.planners.registry import plan_station  # noqa: E402

from dresspack_gym.cable.config import DresspackConfig  # noqa: E402
from dresspack_gym.io.loading import load_station, read_yaml  # noqa: E402
from dresspack_gym.stations.station import Station  # noqa: E402

RATED = Path(__file__).resolve().parents[2] / "configs" / "dresspacks" / "stud_welding_rated.yaml"


@pytest.mark.slow  # an ompl and an ompl-wear plan with their cable simulations (~3 min on 2 cores)
def test_the_life_objective_plans_a_longer_lived_cable_than_ompl():
    config = load_station("default")
    rated = DresspackConfig.from_dict(read_yaml(RATED))
    station = Station(replace(config, robots=(replace(config.robots[0], dresspack=rated),)))
    welds = ["sill_rear", "roof_rail_top"]
    ompl = plan_station(station, "ompl", seed=0, welds=welds).replay.summary()
    life = plan_station(station, "ompl-wear", seed=0, welds=welds, cost_variant="life").replay.summary()
    assert life["life_cycles"] > 1.2 * ompl["life_cycles"], (life["life_cycles"], ompl["life_cycles"])
