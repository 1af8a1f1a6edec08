"""Robot-obstacle collision queries: the fast yes/no check agrees with the exact minimum distance."""

import numpy as np

from dresspack_gym.collision import RobotCollisionChecker
from dresspack_gym.kinematics import weld_pose
from dresspack_gym.loading import load_station
from dresspack_gym.station import Station


def test_collides_agrees_with_exact_min_distance():
    station = Station(load_station("default"))
    checker = RobotCollisionChecker(station)
    lim = station.config.robots[0].robot.joint_limits
    qs = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], size=(600, 6))
    fast = checker.collides_batch(qs)
    exact = np.array([checker.min_distance(q) < 0.0 for q in qs])
    np.testing.assert_array_equal(fast, exact)
    assert 0.02 < fast.mean() < 0.9  # both outcomes occur


def test_tool_pushed_into_an_obstacle_collides_and_margin_grows_the_robot():
    station = Station(load_station("default"))
    checker = RobotCollisionChecker(station)
    kin = station.robots[0].kinematics
    inside = kin.ik(weld_pose([1.3, 0.0, 1.05], [1, 0, 0], 0.0))  # TCP 15 cm inside the B-pillar
    assert len(inside) and all(checker.collides(q) for q in inside)
    assert not checker.collides(station.home[0])
    gap = checker.min_distance(station.home[0])
    assert RobotCollisionChecker(station, margin=gap + 0.01).collides(station.home[0])
