"""Every shipped station builds, settles at Home with finite measures, and has reachable welds."""

import numpy as np
import pytest

from dresspack_gym.loading import list_stations, load_station
from dresspack_gym.tasks import allowed_weld_configurations
from dresspack_gym.simulation import CableSimulator
from dresspack_gym.station import Station


def test_the_default_and_the_three_thesis_scenarios_are_shipped():
    assert {"default", "thesis_curvature", "thesis_tension", "thesis_distance"} <= set(list_stations())


@pytest.mark.parametrize("name", list_stations())
def test_station_settles_with_finite_measures(name):
    station = Station(load_station(name))
    sim = CableSimulator(station)
    m = sim.measures()
    assert all(np.isfinite([m.max_curvature, m.max_tension, m.min_clearance, m.max_twist_rate]))
    assert sim.max_vertex_speed() < 0.05
    for w in station.config.weld_points:
        assert len(allowed_weld_configurations(station, station.config.robot_index(w.robot), w.name)) > 0
