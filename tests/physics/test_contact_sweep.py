"""A robot link sweeping through a hanging cable pushes it aside: bounded penetration and force, at the motion
steps the product uses (issue: cable physics v3, contact without jams)."""

import copy

import numpy as np
import pytest
from helpers import THESIS_CABLE

from dresspack_gym.io.loading import station_from_dict
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station


def _sweep_station(x: float, timestep: float) -> Station:
    """The IRB 6700 at the origin turning j1 from -20 deg; a cable (robot contact on) hangs from a world clamp
    at 2.9 m, at radius ``x`` on the +30 deg ray, so the arm (upper arm, forearm or wrist by ``x``) runs into it."""
    dp = copy.deepcopy(THESIS_CABLE)
    dp["collide_with_robot"] = True
    a = np.radians(30.0)
    dp["nodes"] = [{"name": "top", "body": "world", "pos": [x * np.cos(a), x * np.sin(a), 2.9],
                    "direction": [0, 0, -1]}]
    data = {"name": "sweep", "robots": [{"name": "r1", "robot": "abb_irb6700_200_260", "dresspack": dp,
                                         "base_pos": [0, 0, 0], "home_deg": [-20, 0, 0, 0, 0, 0]}],
            "obstacles": [], "floor": False, "simulation": {"timestep": timestep}}
    return Station(station_from_dict(data))


@pytest.mark.parametrize("timestep", [0.002, 0.008])
@pytest.mark.parametrize("x", [0.6, 0.9, 1.3])
def test_a_sweeping_link_pushes_the_cable_aside(x, timestep):
    station = _sweep_station(x, timestep)
    sim = CableSimulator(station)
    d = sim.data
    radius = station.config.robots[0].dresspack.radius
    weight = 1.25 * 9.81 * 1.74
    start = sim.cable_points()[-1].copy()
    depth = []

    def deepest(_t):
        depth.append(max([-c.dist for c in d.contact[:d.ncon]], default=0.0))

    target = station.home.copy()
    target[0, 0] = np.radians(80)
    trace = sim.move_to(target, record_every=timestep, on_sample=deepest, settle=False)  # the default program speed
    assert max(depth) > 0.0  # the arm did reach the cable
    assert max(depth) < radius / 2  # measured 4-10 mm against r/2 = 15 mm
    assert max(m.max_tension for m in trace.measures) < 4 * weight  # measured 34-60 N; the cable weighs 21 N
    assert np.linalg.norm(sim.cable_points()[-1] - start) > 0.3  # pushed aside, not cut through
