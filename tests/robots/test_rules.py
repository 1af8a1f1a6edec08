"""Rules with one owner: joint-limit tolerance and message, config equality, choices (the time law: test_time_law)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import check_choice
from dresspack_gym.io.loading import load_station
from dresspack_gym.robots.joint_limits import LIMIT_TOL, check_within_limits, within_limits


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


def test_bad_choice_names_the_field_and_the_allowed_values():
    assert check_choice("planner", "ompl", ["ompl", "ppo"]) == "ompl"
    with pytest.raises(ConfigError, match=r"planner: 'astar' is not one of the allowed values \['ompl', 'ppo'\]"):
        check_choice("planner", "astar", ["ompl", "ppo"])


