"""Every shipped station builds, settles at Home with finite measures, and has reachable welds."""

import numpy as np
import pytest

from dresspack_gym.io.loading import list_stations, load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import allowed_weld_configurations


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


def test_four_robot_station_every_weld_reachable_by_its_robot_and_cables_apart():
    """side_framing_4r: 4 robots, 40 weld points, each with a restriction-passing, collision-free IK branch for
    its assigned robot; every cable settles at Home without touching another robot or cable."""
    from dresspack_gym.io.loading import load_station
    from dresspack_gym.physics.simulation import CableSimulator
    from dresspack_gym.stations.station import Station
    from dresspack_gym.stations.tasks import select_weld_goals
    from dresspack_gym.stations.validity import PLANNER_MARGIN, MotionValidity

    station = Station(load_station("side_framing_4r"))
    assert station.n_robots == 4 and len(station.config.weld_points) == 40 and not station.unreachable_welds
    for i, r in enumerate(station.config.robots):
        validity = MotionValidity(station, i, margin=PLANNER_MARGIN)
        assert validity.valid(r.home)
        names = [w.name for w in station.config.weld_points if w.robot == r.name]
        assert len(names) == 10
        goals = select_weld_goals(station, i, validity.checker.collides, names)
        assert all(validity.valid(q) for q in goals.values())
    sim = CableSimulator(station)
    assert sim.last_settle.converged
    assert all(s.normal_force.sum() == 0.0 for s in sim.segment_states())


def test_the_held_out_variant_moves_the_car_body_and_adds_a_clamp_column():
    base, variant = load_station("default"), load_station("default_variant")
    moved = {o.name: o for o in variant.obstacles}
    assert set(moved) - {o.name for o in base.obstacles} == {"clamp_column"}
    for o in base.obstacles:
        shift = np.asarray(moved[o.name].pos) - np.asarray(o.pos)
        expected = (0.0, 0.0, 0.0) if o.name == "cabinet" else (0.12, -0.10, 0.0)
        np.testing.assert_allclose(shift, expected, atol=1e-12, err_msg=o.name)
    assert [r.robot.name for r in variant.robots] == [r.robot.name for r in base.robots]


def test_the_fifty_weld_station_is_the_four_robot_station_with_ten_more_welds():
    """side_framing_4r_50 (the multi-robot issue's scale case) changes nothing of side_framing_4r but adds ten
    welds, each reachable by the robot it names (test_station_settles_with_finite_measures)."""
    base, big = load_station("side_framing_4r"), load_station("side_framing_4r_50")
    assert big.robots == base.robots and big.obstacles == base.obstacles and big.wear_cost == base.wear_cost
    assert big.weld_points[:40] == base.weld_points and len(big.weld_points) == 50
    assert len({w.name for w in big.weld_points}) == 50
