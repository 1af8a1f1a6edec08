"""The time law against the analytic jerk-limited rest-to-rest profile, its limits, and every user timing alike."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory
from dresspack_gym.robots.config import ACCELERATION_TIME, JERK_TIME, RobotConfig
from dresspack_gym.robots.time_law import (
    BATCH,
    JointLimits,
    SegmentMotion,
    path_duration,
    segment_durations,
    velocity_bound,
)
from dresspack_gym.stations.station import Station

V = np.radians([110.0, 110.0, 110.0, 190.0, 150.0, 210.0])
LIMITS = JointLimits(V, V / 0.25, V / 0.025)


def s_curve_time(d: float, v: float, a: float, j: float) -> float:
    """Minimum time of a rest-to-rest move of length d (one axis), by hand: symmetric jerk-limited phases, the
    cruise at v if there is room, else the highest peak speed that fits (with or without reaching a)."""
    def ramp(w):  # (time, distance) to reach speed w from rest
        t = w / a + a / j if w >= a * a / j else 2.0 * np.sqrt(w / j)
        return t, 0.5 * w * t
    t_ramp, d_ramp = ramp(v)
    if 2 * d_ramp <= d:
        return 2 * t_ramp + (d - 2 * d_ramp) / v
    w = (d * np.sqrt(j) / 2) ** (2 / 3)  # peak speed without reaching a: d = 2 w sqrt(w / j)
    if w >= a * a / j:  # a is reached: d = w (w / a + a / j)
        w = 0.5 * a * (-a / j + np.sqrt((a / j) ** 2 + 4 * d / a))
    return 2 * ramp(w)[0]


@pytest.mark.parametrize("deg", [0.05, 2.0, 10.0, 45.0, 170.0])  # no a, a without v, v reached
def test_single_joint_time_is_the_analytic_s_curve(deg):
    dq = np.zeros(6)
    dq[0] = np.radians(deg)
    expected = s_curve_time(dq[0], V[0], V[0] / 0.25, V[0] / 0.025)
    assert float(segment_durations(dq, LIMITS)) == pytest.approx(expected, rel=1e-9)
    assert SegmentMotion(dq, LIMITS).duration == pytest.approx(expected, rel=1e-9)


def test_a_straight_move_is_timed_by_its_tightest_joint_scalar_limits():
    # joint 1 moves 60 deg, joint 4 moves 150 deg: each scalar limit is the tighter joint's (v_i / |dq_i|)
    dq = np.radians([60.0, 0, 0, 150.0, 0, 0])
    r = np.abs(dq[[0, 3]])
    v, a, j = (np.min(x[[0, 3]] / r) for x in (LIMITS.velocity, LIMITS.acceleration, LIMITS.jerk))
    assert float(segment_durations(dq, LIMITS)) == pytest.approx(s_curve_time(1.0, v, a, j), rel=1e-9)


def test_sampled_motion_is_straight_within_every_limit_and_ends_at_rest():
    rng = np.random.default_rng(3)
    dt = 0.001
    for _ in range(20):
        dq = rng.uniform(-2.0, 2.0, 6) * (rng.random(6) < 0.7)
        motion = SegmentMotion(dq, LIMITS)
        frac, rate = motion.on_steps(dt)
        assert len(frac) == int(np.ceil(motion.duration / dt - 1e-9)) and frac[-1] == 1.0
        q = frac[:, None] * dq  # straight by construction: check the limits it implies
        qd = rate[:, None] * dq
        assert np.all(np.abs(qd) <= LIMITS.velocity * (1 + 1e-9))
        qdd = np.diff(np.vstack([np.zeros(6), qd, np.zeros(6)]), axis=0) / dt  # at rest before and after
        assert np.all(np.abs(qdd) <= LIMITS.acceleration * (1 + 1e-6) + LIMITS.jerk * dt)
        np.testing.assert_allclose(np.diff(np.vstack([np.zeros(6), q]), axis=0) / dt,
                                   0.5 * (qd + np.vstack([np.zeros(6), qd[:-1]])), atol=LIMITS.jerk.max() * dt ** 2)
        assert rate[-1] == pytest.approx(0.0, abs=1e-9)


def test_velocity_only_follows_the_speed_fraction():
    dq = np.radians([170.0, 0, 0, 0, 0, 0])  # long: mostly cruising
    full = float(segment_durations(dq, LIMITS))
    half = float(segment_durations(dq, LIMITS.at_speed(0.5)))
    a, j = LIMITS.acceleration[0], LIMITS.jerk[0]
    assert half == pytest.approx(s_curve_time(dq[0], 0.5 * V[0], a, j), rel=1e-9)
    assert 1.5 * full < half < 2 * full  # the ramps do not stretch with the programmed speed
    tiny = np.radians([0.01, 0, 0, 0, 0, 0])  # never reaches either speed: the same time
    assert float(segment_durations(tiny, LIMITS.at_speed(0.5))) == pytest.approx(float(segment_durations(tiny, LIMITS)))


def test_bulk_durations_match_single_motions_across_batches_and_bound_from_below():
    rng = np.random.default_rng(0)
    dq = rng.uniform(-3.0, 3.0, (BATCH + 37, 6))
    dq[5] = 0.0  # no motion
    dq[7] = 1e-14  # below the still threshold
    bulk = segment_durations(dq, LIMITS)
    assert bulk[5] == 0.0 and bulk[7] == 0.0
    for i in (0, 1, BATCH - 1, BATCH, BATCH + 36):
        assert bulk[i] == pytest.approx(SegmentMotion(dq[i], LIMITS).duration, rel=1e-12)
    assert np.all(velocity_bound(dq, LIMITS) <= bulk + 1e-12)
    grid = segment_durations(dq[:60].reshape(6, 10, 6), LIMITS)
    np.testing.assert_array_equal(grid.ravel(), bulk[:60])
    pts = np.cumsum(dq[:4], axis=0)
    assert path_duration(pts, LIMITS) == pytest.approx(bulk[1:4].sum())


def test_several_robots_share_one_motion_within_each_robots_limits():
    slow = JointLimits(V * 0.5, V, V * 10)
    both = JointLimits.stack([LIMITS, slow])
    dq = np.zeros((2, 6))
    dq[0, 0] = dq[1, 0] = 1.0
    t = float(segment_durations(dq, both))
    assert t == pytest.approx(float(segment_durations(dq[1], slow)), rel=1e-12)  # the slow robot sets the time
    frac, rate = SegmentMotion(dq, both).on_steps(0.001)
    assert np.max(rate) * 1.0 <= slow.velocity[0] * (1 + 1e-9)


def test_robot_yaml_limits_and_documented_defaults():
    station = load_station("default")
    robot = station.robots[0].robot
    np.testing.assert_allclose(robot.joint_acceleration, robot.joint_speed / ACCELERATION_TIME)
    np.testing.assert_allclose(robot.joint_jerk, robot.joint_acceleration / JERK_TIME)
    data = {"name": "r", "source": "s", "kinematics": {"a1": 0.3, "d1": 0.7, "a2": 1.0, "a3": 0.2, "d4": 1.0,
                                                      "d6": 0.2},
            "joint_limits_deg": [[-170, 170]] * 6, "joint_speed_deg_s": [100] * 6,
            "joint_acceleration_deg_s2": [300] * 6, "tool": {"tcp_pos": [0.4, 0, 0]}}
    r = RobotConfig.from_dict(data)
    np.testing.assert_allclose(r.joint_acceleration, np.radians(300.0))
    np.testing.assert_allclose(r.joint_jerk, np.radians(300.0) / JERK_TIME)
    with pytest.raises(ConfigError, match=r"robot.joint_jerk_deg_s3"):
        RobotConfig.from_dict({**data, "joint_jerk_deg_s3": [0] * 6})
    with pytest.raises(ConfigError, match=r"robot.joint_acceleration_deg_s2"):
        RobotConfig.from_dict({**data, "joint_acceleration_deg_s2": [300] * 5})


def test_the_simulator_the_trajectory_and_the_programs_use_one_time_law():
    from dresspack_gym.io.programs import TimedPath

    config = load_station("thesis_curvature")
    station = Station(config)
    sim = CableSimulator(station)
    q0 = station.home[0]
    q1 = q0 + np.radians([30, -10, 5, 40, 0, 0])
    robot = config.robots[0].robot
    limits = robot.joint_motion_limits.at_speed(config.simulation.speed_fraction)
    expected = float(segment_durations(q1 - q0, limits))
    sim.move_to(q1, settle=False)
    assert sim.motion_time == pytest.approx(expected, abs=station.model.opt.timestep)
    traj = Trajectory(np.array([q0, q1]), (1,))
    assert traj.segment_durations(limits)[0] == pytest.approx(expected, rel=1e-12)
    timed = TimedPath.of(traj, robot, config.simulation.speed_fraction)
    assert timed.times[-1] == pytest.approx(expected, rel=1e-12)
    # a robot stating slower accelerations moves the same path more slowly
    sluggish = replace(robot, joint_acceleration_rad_s2=tuple(robot.joint_acceleration / 4))
    assert TimedPath.of(traj, sluggish, config.simulation.speed_fraction).times[-1] > expected * 1.2


def test_quasi_static_slowing_is_a_pure_time_scaling():
    """``slowed(f)`` (the robustness mapper's excursions) runs the full-speed profile 1/f times slower, in every
    regime, so its accelerations shrink with f^2 (a velocity-only scaling would keep them)."""
    rng = np.random.default_rng(5)
    dq = rng.uniform(-2.0, 2.0, (50, 6))
    dq[:10] *= 1e-3  # tiny moves: jerk-limited only
    for f in (0.5, 0.25, 1 / 16):
        np.testing.assert_allclose(segment_durations(dq, LIMITS.slowed(f)), segment_durations(dq, LIMITS) / f,
                                   rtol=1e-9)
        m = SegmentMotion(dq[20], LIMITS.slowed(f))
        assert m.peak_acceleration == pytest.approx(SegmentMotion(dq[20], LIMITS).peak_acceleration * f ** 2,
                                                    rel=1e-9)


# ---------------------------------------------------------------------------- paths flown by their via points
def _bounded(motion, limits, n=4000):
    """The motion sampled densely: (positions, velocities) and whether every joint keeps its velocity limit."""
    t = np.linspace(0.0, motion.duration, n)
    q, qd = motion.at(t)
    return q, qd, bool(np.all(np.abs(qd) <= limits.velocity + 1e-9))


def test_a_path_that_stops_at_every_via_point_is_the_straight_segments():
    from dresspack_gym.robots.time_law import PathMotion

    pts = np.radians([[0, 0, 0, 0, 0, 0], [40, 10, 0, 0, 30, 0], [60, -20, 5, 90, 30, 0], [20, -20, 5, 0, 0, 10]])
    m = PathMotion(pts, LIMITS)
    assert m.duration == pytest.approx(path_duration(pts, LIMITS))
    q, _ = m.at(m.section_starts + m.section_durations * 0.5)  # half way in time: on each segment
    for k, x in enumerate(q):
        d = pts[k + 1] - pts[k]
        f = np.dot(x - pts[k], d) / np.dot(d, d)
        np.testing.assert_allclose(x, pts[k] + f * d, atol=1e-9)


def test_flying_by_passes_every_via_point_within_the_limits_and_is_faster():
    from dresspack_gym.robots.time_law import PathMotion, pass_velocities

    pts = np.radians([[0, 0, 0, 0, 0, 0], [40, 10, 0, 0, 30, 0], [60, -20, 5, 90, 30, 0], [20, -20, 5, 0, 0, 10]])
    fly = PathMotion(pts, LIMITS, fly_by=True)
    stop = PathMotion(pts, LIMITS)
    assert fly.duration < stop.duration
    q, qd = fly.at(fly.section_starts)
    np.testing.assert_allclose(q, pts[:-1], atol=1e-9)  # each section starts at its point ...
    np.testing.assert_allclose(qd, pass_velocities(pts, LIMITS)[:-1], atol=1e-9)  # ... at its pass velocity
    end_q, end_qd = fly.at([fly.duration, fly.duration + 1.0])
    np.testing.assert_allclose(end_q, pts[[-1, -1]])
    np.testing.assert_array_equal(end_qd, 0.0)
    _, _, within = _bounded(fly, LIMITS)
    assert within and fly.peak_acceleration() <= LIMITS.acceleration.max() + 1e-9
    # a joint that turns back at a via point passes it at rest; one that keeps going does not
    v = pass_velocities(pts, LIMITS)
    assert v[1, 1] == 0.0 and v[2, 0] == 0.0  # joint 2 goes up then down; joint 1 up then back at point 2
    assert v[1, 0] > 0 and v[1, 3] == 0.0  # joint 4 does not move into point 1


def test_flying_by_a_point_on_a_straight_line_keeps_to_the_line():
    """Through a via point half way along a straight move: every joint keeps its direction, so the pass velocity
    is the half segment's peak, the synchronised sections stay on the line, and the time lies between the
    straight move's (no stop, the fastest) and the two halves' (a stop)."""
    from dresspack_gym.robots.time_law import PathMotion, pass_velocities

    a, b = np.zeros(6), np.radians([100.0, 50.0, 0.0, 0.0, 20.0, 0.0])
    pts = np.array([a, 0.5 * (a + b), b])
    half = SegmentMotion(pts[1] - pts[0], LIMITS)
    np.testing.assert_allclose(pass_velocities(pts, LIMITS)[1], half.peak_rate * (pts[1] - pts[0]))
    fly = PathMotion(pts, LIMITS, fly_by=True)
    q, _, within = _bounded(fly, LIMITS)
    f = q @ (b - a) / np.dot(b - a, b - a)
    np.testing.assert_allclose(q, f[:, None] * (b - a), atol=1e-9)
    assert within and path_duration(pts[[0, 2]], LIMITS) < fly.duration < 2 * half.duration


@pytest.mark.parametrize("deg", [0.05, 2.0, 10.0, 45.0, 170.0])  # no a, a without v, v reached
def test_peak_jerk_of_a_single_joint_move_is_its_jerk_limit(deg):
    """A time-optimal rest-to-rest move switches between ±J at every phase boundary, whichever limits it reaches:
    the export check's peak jerk of the path fraction [1/s^3], times the joint's change, is the joint's jerk limit
    (and its peak rate the speed limit once the move is long enough to reach it)."""
    dq = np.zeros(6)
    dq[0] = np.radians(deg)
    m = SegmentMotion(dq, LIMITS)
    assert m.peak_jerk * dq[0] == pytest.approx(LIMITS.jerk[0], rel=1e-9)
    assert m.peak_rate * dq[0] <= LIMITS.velocity[0] * (1 + 1e-9)
    if deg >= 45.0:
        assert m.peak_rate * dq[0] == pytest.approx(LIMITS.velocity[0], rel=1e-9)
