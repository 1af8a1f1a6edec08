"""Forward kinematics against MuJoCo's body frames; analytic IK round trips on thousands of poses."""

import mujoco
import numpy as np
import pytest

from dresspack_gym.io.loading import load_robot, load_station
from dresspack_gym.robots.kinematics import RobotKinematics, weld_configurations, weld_pose, wrap_angle
from dresspack_gym.stations.station import Station

ROBOT = load_robot("abb_irb6700_200_260")


def random_configurations(rng, n, kin):
    lim = kin.limits
    return rng.uniform(lim[:, 0], lim[:, 1], size=(n, 6))


def test_forward_kinematics_matches_mujoco_model():
    station = Station(load_station("default"))
    rob = station.robots[0]
    m = station.model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for q in random_configurations(rng, 50, rob.kinematics):
        d.qpos[rob.qpos] = q
        mujoco.mj_kinematics(m, d)
        tcp = rob.kinematics.tcp_pose(q)
        np.testing.assert_allclose(d.site_xpos[rob.tcp_site], tcp[:3, 3], atol=1e-9)
        np.testing.assert_allclose(d.site_xmat[rob.tcp_site].reshape(3, 3), tcp[:3, :3], atol=1e-9)
        frames = rob.kinematics.link_frames(q)
        for i, link in enumerate(["link1", "link2", "link3", "link4", "link5", "link6"], start=1):
            bid = m.body(f"r1/{link}").id
            np.testing.assert_allclose(d.xpos[bid], frames[i][:3, 3], atol=1e-9)


# the moved, turned base's 3,000 poses take ~10 s: the full sweep runs in the slow tier
@pytest.mark.parametrize("base_pos, base_yaw", [((0, 0, 0), 0.0),
                                                pytest.param((1.5, -0.7, 0.3), 2.1, marks=pytest.mark.slow)])
def test_ik_round_trip_on_thousands_of_random_poses(base_pos, base_yaw):
    """FK(q) = T, then every IK solution reproduces T and q itself is among the solutions."""
    kin = RobotKinematics(ROBOT, base_pos, base_yaw)
    rng = np.random.default_rng(1)
    qs = random_configurations(rng, 3000, kin)
    checked = 0
    for q in qs:
        wrist = kin.link_frames(q)[5][:3, 3] - np.asarray(base_pos)
        if abs(np.sin(q[4])) < 1e-3 or np.hypot(wrist[0], wrist[1]) < 1e-3:
            continue  # wrist or shoulder singularity: infinitely many solutions
        target = kin.tcp_pose(q)
        sols = kin.ik(target)
        assert 1 <= len(sols)
        for s in sols:
            np.testing.assert_allclose(kin.tcp_pose(s), target, atol=1e-8)
        assert kin.within_limits(sols).all()
        assert np.min(np.max(np.abs(sols - q), axis=1)) < 1e-7
        checked += 1
    assert checked > 2900


def test_ik_returns_all_eight_branches_for_a_generic_pose():
    kin = RobotKinematics(ROBOT)
    q = np.array([0.41, -0.69, -1.38, -1.45, 0.94, 1.24])  # wrist near the j1 axis: back solutions exist
    raw = kin.ik_flange(kin.flange(q), within_limits=False)
    assert len(raw) == 8  # front/back x elbow up/down x wrist flip
    assert len(np.unique(np.round(raw, 6), axis=0)) == 8
    for s in raw:
        np.testing.assert_allclose(kin.flange(s), kin.flange(q), atol=1e-8)


def test_unreachable_pose_gives_no_solution():
    kin = RobotKinematics(ROBOT)
    target = np.eye(4)
    target[:3, 3] = [5.0, 0.0, 1.0]  # twice the reach
    assert len(kin.ik(target)) == 0


def test_weld_pose_tool_axis_is_the_approach_direction():
    for approach in ([0, 0, -1], [1, 0, 0], [0.3, -0.5, 0.8]):
        pose = weld_pose([1, 0, 1], approach, 0.7)
        a = np.asarray(approach, float) / np.linalg.norm(approach)
        np.testing.assert_allclose(pose[:3, 2], a, atol=1e-12)
        np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-12)


def test_default_station_weld_points_are_reached_by_all_listed_configurations():
    station = Station(load_station("default"))
    kin = station.robots[0].kinematics
    for w in station.config.weld_points:
        sols = weld_configurations(kin, w)
        assert len(sols) >= 8
        for s in sols[:: max(1, len(sols) // 10)]:
            tcp = kin.tcp_pose(s)
            np.testing.assert_allclose(tcp[:3, 3], w.pos, atol=1e-8)
            np.testing.assert_allclose(tcp[:3, 2], w.approach, atol=1e-8)


def test_wrap_angle_range():
    a = np.linspace(-10, 10, 1001)
    w = wrap_angle(a)
    assert np.all(w > -np.pi - 1e-12) and np.all(w <= np.pi + 1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
