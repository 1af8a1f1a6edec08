"""Every shipped robot passes the same checks: its MuJoCo body chain is its kinematics, the analytic IK round trips
with all eight branches, a station built with it settles, and its controller axis mapping reproduces the maker's
own joint chain."""

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from dresspack_gym.config import RobotConfig
from dresspack_gym.errors import ConfigError
from dresspack_gym.kinematics import RobotKinematics, weld_configurations
from dresspack_gym.loading import list_robots, load_robot, load_station, read_yaml
from dresspack_gym.robot_check import ik_round_trip
from dresspack_gym.shipped import find_shipped
from dresspack_gym.simulation import CableSimulator
from dresspack_gym.station import Station

ROBOTS = list_robots()

# Each axis's joint origin (in the parent link's frame, zero pose) and turning axis, from the makers' data as
# ROS-Industrial publishes it (kuka_experimental kr210r2700extra_macro.xacro, fanuc r2000ic210f_macro.xacro);
# the last origin is the flange.
MAKER_CHAINS = {
    "kuka_kr210_r2700_extra": [((0, 0, 0.675), (0, 0, -1)), ((0.350, 0, 0), (0, 1, 0)), ((1.150, 0, 0), (0, 1, 0)),
                               ((0, 0, -0.041), (-1, 0, 0)), ((1.200, 0, 0), (0, 1, 0)), ((0.215, 0, 0), (-1, 0, 0))],
    "fanuc_r2000ic_210f": [((0, 0, 0.670), (0, 0, 1)), ((0.312, 0, 0), (0, 1, 0)), ((0, 0, 1.075), (0, -1, 0)),
                           ((0, 0, 0.225), (-1, 0, 0)), ((1.280, 0, 0), (0, -1, 0)), ((0.215, 0, 0), (-1, 0, 0))],
}


def _maker_flange(chain, axes) -> np.ndarray:
    t = np.eye(4)
    for (origin, axis), a in zip(chain, axes):
        step = np.eye(4)
        step[:3, 3] = origin
        rot = np.zeros(9)
        quat = np.zeros(4)
        mujoco.mju_axisAngle2Quat(quat, np.asarray(axis, float), float(a))
        mujoco.mju_quat2Mat(rot, quat)
        step[:3, :3] = rot.reshape(3, 3)
        t = t @ step
    return t


def test_more_than_one_maker_is_shipped():
    assert {"abb_irb6700_200_260", "kuka_kr210_r2700_extra", "fanuc_r2000ic_210f"} <= set(ROBOTS)


@pytest.mark.parametrize("name", ROBOTS)
def test_ik_round_trip_with_all_branches(name):
    r = ik_round_trip(load_robot(name), poses=500, seed=1, base_pos=(1.5, -0.7, 0.3), base_yaw=2.1)
    assert r.poses > 480
    assert r.max_pose_error < 1e-8 and r.found_q and r.max_joint_error < 1e-7
    assert r.max_raw_branches == 8 and r.mean_branches >= 8


@pytest.mark.parametrize("name", ROBOTS)
def test_mujoco_chain_is_the_kinematics_and_the_cable_settles(name):
    """The default station with this robot: body frames and TCP equal the analytic FK, the cable settles to
    equilibrium at Home and every weld point has a configuration."""
    cfg = load_station("default")
    cfg = replace(cfg, robots=(replace(cfg.robots[0], robot=load_robot(name)),))
    station = Station(cfg)
    rob = station.robots[0]
    m, d = station.model, mujoco.MjData(station.model)
    lim = rob.kinematics.limits
    for q in np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], size=(30, 6)):
        d.qpos[rob.qpos] = q
        mujoco.mj_kinematics(m, d)
        tcp = rob.kinematics.tcp_pose(q)
        np.testing.assert_allclose(d.site_xpos[rob.tcp_site], tcp[:3, 3], atol=1e-9)
        np.testing.assert_allclose(d.site_xmat[rob.tcp_site].reshape(3, 3), tcp[:3, :3], atol=1e-9)
        for i, frame in enumerate(rob.kinematics.link_frames(q)[1:7], start=1):
            np.testing.assert_allclose(d.xpos[m.body(f"r1/link{i}").id], frame[:3, 3], atol=1e-9)
    sim = CableSimulator(station)
    assert sim.settle().equilibrium.converged
    for w in cfg.weld_points:
        assert len(weld_configurations(rob.kinematics, w)) > 0


@pytest.mark.parametrize("name", sorted(MAKER_CHAINS))
def test_controller_axes_reproduce_the_makers_joint_chain(name):
    robot = load_robot(name)
    kin = RobotKinematics(robot)
    lim = kin.limits
    for q in np.random.default_rng(2).uniform(lim[:, 0], lim[:, 1], size=(200, 6)):
        axes = robot.to_controller(q)
        np.testing.assert_allclose(robot.from_controller(axes), q, atol=1e-12)
        ours, maker = kin.flange(q), _maker_flange(MAKER_CHAINS[name], axes)
        np.testing.assert_allclose(ours[:3, 3], maker[:3, 3], atol=1e-9)
        np.testing.assert_allclose(ours[:3, :3], maker[:3, :3], atol=1e-9)


def test_a_wrong_controller_mapping_is_caught_by_the_maker_chain():
    """The check above can fail: KUKA's A2 counted from the vertical (no offset) misplaces the flange."""
    robot = load_robot("kuka_kr210_r2700_extra")
    wrong = replace(robot, controller_offset_rad=(0.0,) * 6)
    q = np.radians([10, 20, -30, 40, 50, 60])
    assert np.linalg.norm(RobotKinematics(robot).flange(q)[:3, 3]
                          - _maker_flange(MAKER_CHAINS["kuka_kr210_r2700_extra"], wrong.to_controller(q))[:3, 3]) > 0.5


@pytest.mark.parametrize("patch,field", [
    ({"controller_axes": {"sign": [2, 1, 1, 1, 1, 1]}}, "controller_axes.sign[0]"),
    ({"controller_axes": {"sign": [1, 1, 1]}}, "controller_axes.sign"),
    ({"controller_axes": {"offset_deg": [0, 0, 0, 0, 0, 400]}}, "controller_axes.offset_deg"),
    ({"controller_axes": {"zero": [0] * 6}}, "controller_axes.zero"),
])
def test_bad_controller_axes_name_the_field(patch, field):
    data = read_yaml(find_shipped("kuka_kr210_r2700_extra", "robots", "robot"))
    with pytest.raises(ConfigError) as exc:
        RobotConfig.from_dict({**data, **patch}, path="robot")
    assert field in str(exc.value)
