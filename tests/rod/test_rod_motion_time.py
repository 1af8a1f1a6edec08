"""The rod engine runs the time law's motion unslowed: a move's motion time is the time law's duration."""

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.robots.time_law import SegmentMotion
from dresspack_gym.rod.simulator import RodSimulator, whole_samples
from dresspack_gym.stations.station import Station


@pytest.mark.parametrize("sample", [0.05, 0.02, 0.013])
def test_whole_samples_divide_the_duration_and_never_exceed_the_sample(sample):
    limits = load_station("default").robots[0].robot.joint_motion_limits.at_speed(0.5)
    for delta in np.radians([[10, 0, 0, 0, 0, 0], [40, -20, 15, 90, 30, -60], [0.1, 0, 0, 0, 0, 0]]):
        motion = SegmentMotion(delta, limits)
        fractions, h = whole_samples(motion, sample)
        assert h <= sample + 1e-15 and len(fractions) * h == pytest.approx(motion.duration, abs=1e-12)
        assert fractions[-1] == 1.0 and np.all(np.diff(fractions) >= 0.0)


def test_a_moves_motion_time_is_the_time_laws_duration():
    station = Station(load_station("default"))
    sim = RodSimulator(station)
    target = station.home.copy()
    target[0] += np.radians([20, 5, -5, 30, 10, -20])
    duration = SegmentMotion(target[0] - station.home[0], sim.motion_limits()).duration
    sim.move_to(target, settle=False)
    assert sim.motion_time == pytest.approx(duration, abs=1e-12)
