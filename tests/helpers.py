"""Small inline stations for tests: a parked robot and a cable held by world nodes (analytic cases)."""

from __future__ import annotations

import copy

import numpy as np

from dresspack_gym.io.loading import station_from_dict
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station

THESIS_CABLE = {
    "name": "test_cable", "length": 1.74, "radius": 0.03, "linear_density": 1.25,
    "bending_stiffness": 0.1, "tensile_stiffness": 1400, "torsional_stiffness": 0.1,
    "segments": 24, "collide_with_robot": False,
}


def world_cable_station(nodes, *, cable=None, obstacles=(), gravity=9.81, floor=False, simulation=None):
    """A station whose only dresspack hangs from world nodes; the robot is parked far away."""
    dp = copy.deepcopy(THESIS_CABLE)
    dp.update(cable or {})
    dp["nodes"] = list(nodes)
    sim = {"gravity": gravity}
    sim.update(simulation or {})
    data = {
        "name": "test_station",
        "robots": [{"name": "r1", "robot": "abb_irb6700_200_260", "dresspack": dp,
                    "base_pos": [-20, -20, 0], "home_deg": [0, 0, 0, 0, 0, 0]}],
        "obstacles": list(obstacles),
        "floor": floor,
        "simulation": sim,
    }
    return Station(station_from_dict(data))


def settled(station: Station, seconds: float = 6.0) -> CableSimulator:
    sim = CableSimulator(station)
    sim.settle(seconds)
    return sim


def default_station_dict():
    from dresspack_gym.io.loading import read_yaml, resolve_station_path

    return read_yaml(resolve_station_path("default"))


# drawn_0 of `dresspack-eval --drawn-tasks 30 --seeds 0` on the default station: a weld on the body's panel that no
# midpoint via leaves toward Home (docs/primitive_reach.json)
STUCK_WELD = np.array([0.7407122213013433, 1.0980702748831073, -0.7737209529340379, 3.4157926055470913,
                       -1.0514117569148649, 2.196833986149849])
