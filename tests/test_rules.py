"""Rules with one owner: joint-limit tolerance and message, the cubic time law, config equality, choices."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.errors import ConfigError
from dresspack_gym.joint_limits import LIMIT_TOL, check_within_limits, within_limits
from dresspack_gym.loading import load_station
from dresspack_gym.simulation import CableSimulator
from dresspack_gym.station import Station
from dresspack_gym.time_law import CUBIC_PEAK_FACTOR, cubic_position, cubic_speed
from dresspack_gym.trajectory import Trajectory
from dresspack_gym.validation import check_choice


def test_joint_limit_tolerance_and_message():
    limits = np.radians([[-180, 180]] * 6)
    q = np.zeros(6)
    q[2] = limits[2, 1] + 0.5 * LIMIT_TOL
    assert within_limits(q, limits)[0]
    q[2] = limits[2, 1] + 2 * LIMIT_TOL
    assert not within_limits(q, limits)[0]
    q[2] = np.radians(200.0)
    with pytest.raises(ConfigError) as e:
        check_within_limits(q, limits, "home_deg", digits=1)
    assert e.value.field == "home_deg[2]" and "200.0 deg is outside joint 3's limits [-180, 180] deg" in str(e.value)


def test_station_configs_compare_by_value():
    a, b = load_station("default"), load_station("default")
    assert a == b
    moved = replace(a.robots[0], home_rad=(0.1,) + a.robots[0].home_rad[1:])
    assert replace(a, robots=(moved,)) != a
    assert a.robots[0].home is not a.robots[0].home  # a fresh array each time: nobody mutates the config


def test_cubic_time_law_is_the_simulators():
    tau = np.linspace(0, 1, 101)
    assert cubic_position(tau)[[0, -1]].tolist() == [0.0, 1.0]
    assert np.max(cubic_speed(tau, 1.0)) == pytest.approx(CUBIC_PEAK_FACTOR)  # peak = 1.5 x mean speed
    station = Station(load_station("thesis_curvature"))
    sim = CableSimulator(station)
    q0 = station.home[0]
    q1 = q0 + np.radians([30, -10, 5, 40, 0, 0])
    traj = Trajectory(np.array([q0, q1]), (1,))
    sim.move_to(q1, settle=False)
    speeds = station.config.robots[0].robot.joint_speed
    expected = traj.segment_durations(speeds, station.config.simulation.speed_fraction)[0]
    assert sim.motion_time == pytest.approx(expected, abs=station.model.opt.timestep)


def test_bad_choice_names_the_field_and_the_allowed_values():
    assert check_choice("planner", "ompl", ["ompl", "ppo"]) == "ompl"
    with pytest.raises(ConfigError, match=r"planner: 'astar' is not one of the allowed values \['ompl', 'ppo'\]"):
        check_choice("planner", "astar", ["ompl", "ppo"])


