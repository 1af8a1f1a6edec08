"""Smoothness measured alike for every method: reversals counted by hand, peak acceleration against the profile."""

from __future__ import annotations

import numpy as np
import pytest

from dresspack_gym.physics.trajectory import Trajectory, joint_reversals, smoothness
from dresspack_gym.robots.time_law import JointLimits, segment_durations

V = np.radians([110.0, 110.0, 110.0, 190.0, 150.0, 210.0])
LIMITS = JointLimits(V, V / 0.25, V / 0.025)


def _traj(steps_deg) -> Trajectory:
    pts = np.vstack([np.zeros(6), np.cumsum(np.radians(steps_deg), axis=0)])
    return Trajectory(pts, (len(pts) - 1,))


def test_back_and_forth_counts_each_turn():
    steps = [[10, 0, 0, 0, 0, 0], [-10, 0, 0, 0, 0, 0], [10, 5, 0, 0, 0, 0], [0, -5, 0, 0, 0, 0],
             [0, 0, 0, 0, 0, 0]]  # j1 turns twice, j2 once; the still segment counts for no joint
    traj = _traj(steps)
    total = float(segment_durations(np.radians(steps), LIMITS).sum())
    assert smoothness(traj, LIMITS)["reversals_per_s"] == pytest.approx(3 / total)
    np.testing.assert_array_equal(joint_reversals(traj.waypoints), [2, 1, 0, 0, 0, 0])
    straight = _traj([[10, 0, 0, 0, 0, 0], [20, 0, 0, 0, 0, 0]])
    assert smoothness(straight, LIMITS)["reversals_per_s"] == 0.0


def test_peak_acceleration_is_the_limit_on_long_moves_and_analytic_on_tiny_ones():
    long = smoothness(_traj([[170, 0, 0, 0, 0, 0]]), LIMITS)["peak_joint_acceleration"]
    assert long == pytest.approx(LIMITS.acceleration[0], rel=1e-9)  # the ramp reaches joint 1's limit
    d, j = np.radians(0.05), LIMITS.jerk[0]
    tiny = smoothness(_traj([[0.05, 0, 0, 0, 0, 0]]), LIMITS)["peak_joint_acceleration"]
    # neither a nor v reached: four jerk phases of length t, d = 2 j t^3, peak a = j t
    assert tiny == pytest.approx(j * (d / (2 * j)) ** (1 / 3), rel=1e-9)
    assert tiny < LIMITS.acceleration[0]
    # the joint moving most carries the peak; a slower-limited joint moving less does not raise it above its limit
    both = smoothness(_traj([[170, 0, 0, 40, 0, 0]]), LIMITS)["peak_joint_acceleration"]
    assert both == pytest.approx(LIMITS.acceleration[0], rel=1e-9)


def test_a_station_program_is_measured_like_the_same_waypoints_as_one_trajectory():
    """schedule_smoothness of legs that stop at each via point equals smoothness of their waypoints as one
    trajectory (the legs share their ends); flying by the via points lowers the peak acceleration, not the
    reversals."""
    from dresspack_gym.multi.schedule import RobotSchedule
    from dresspack_gym.physics.trajectory import schedule_smoothness

    steps = [[20, 0, 0, 0, 0, 0], [-10, 10, 0, 0, 0, 0], [10, -10, 0, 5, 0, 0], [-20, 0, 0, -5, 0, 0]]
    traj = _traj(steps)
    pts = traj.waypoints
    legs = [pts[0:3], pts[2:5]]
    stopping = RobotSchedule.as_soon_as_possible(0, ["w"], legs, LIMITS, 1.0)
    assert schedule_smoothness(stopping) == pytest.approx(smoothness(traj, LIMITS), rel=1e-12)
    from dresspack_gym.robots.time_law import PathMotion

    flying = RobotSchedule.as_soon_as_possible(0, ["w"], legs, LIMITS, 1.0,
                                               motions=[PathMotion(leg, LIMITS, True) for leg in legs])
    fly, stop = schedule_smoothness(flying), schedule_smoothness(stopping)
    assert fly["reversals_per_s"] * sum(flying.leg_durations()) == stop["reversals_per_s"] * sum(
        stopping.leg_durations())
    assert fly["peak_joint_acceleration"] <= stop["peak_joint_acceleration"] + 1e-9
