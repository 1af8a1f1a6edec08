"""Every shipped robot passes the same checks: its MuJoCo body chain is its kinematics, the analytic IK round trips
with all eight branches, a station built with it settles, and its controller axis mapping reproduces the maker's
own joint chain."""

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import list_robots, load_robot, load_station, read_yaml
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.robots.checks import ik_round_trip
from dresspack_gym.robots.config import RobotConfig
from dresspack_gym.robots.kinematics import RobotKinematics, weld_configurations
from dresspack_gym.shipped import find_shipped
from dresspack_gym.stations.station import Station

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


# ------------------------------------------------------------------------------------ URDF / MJCF in and out
def _chain_urdf(chain, limits=None) -> str:
    """A bare URDF of a joint chain [(origin, axis)...] (no geometry)."""
    from dresspack_gym.robots.importer import _xyz

    inertial = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
                '</inertial>')
    lines, parent = ['<robot name="maker">', '<link name="base_link"/>'], "base_link"
    for i, (origin, axis) in enumerate(chain, start=1):
        lo, hi = limits[i - 1] if limits is not None else (-3.0, 3.0)
        lines += [f'<link name="link_{i}">{inertial}</link>',
                  f'<joint name="joint_{i}" type="revolute"><parent link="{parent}"/><child link="link_{i}"/>'
                  f'<origin xyz="{_xyz(origin)}" rpy="0 0 0"/><axis xyz="{_xyz(axis)}"/>'
                  f'<limit lower="{lo}" upper="{hi}" effort="0" velocity="2"/></joint>']
        parent = f"link_{i}"
    return "\n".join(lines + ["</robot>"])


@pytest.mark.parametrize("name", ROBOTS)
def test_urdf_and_mjcf_round_trip(name, tmp_path):
    """A robot written as URDF / MJCF (in its controller's convention) and read back is the same robot."""
    from dresspack_gym.robots.importer import robot_from_model, to_mjcf, to_urdf

    robot = load_robot(name)
    for suffix, text, tol in ((".urdf", to_urdf(robot), 1e-12), (".xml", to_mjcf(robot), 1e-5)):
        (tmp_path / f"r{suffix}").write_text(text)
        back = robot_from_model(replace(robot, controller_sign=(1.0,) * 6, controller_offset_rad=(0.0,) * 6),
                                tmp_path / f"r{suffix}")
        for k in ("a1", "d1", "a2", "a3", "d4", "d6"):
            assert getattr(back.kinematics, k) == pytest.approx(getattr(robot.kinematics, k), abs=1e-12)
        assert back.controller_sign == robot.controller_sign
        np.testing.assert_allclose(back.controller_offset_rad, robot.controller_offset_rad, atol=1e-12)
        np.testing.assert_allclose(back.joint_limits, robot.joint_limits, atol=tol)  # MJCF writes 6-7 digits
        if suffix == ".urdf":
            np.testing.assert_allclose(back.joint_speed, robot.joint_speed, atol=1e-12)


@pytest.mark.parametrize("name", sorted(MAKER_CHAINS))
def test_the_makers_chain_read_as_urdf_gives_the_shipped_robot(name, tmp_path):
    from dresspack_gym.robots.importer import derive, load_model

    (tmp_path / "m.urdf").write_text(_chain_urdf(MAKER_CHAINS[name]))
    kin, sign, offset, _ = derive(load_model(tmp_path / "m.urdf"))
    robot = load_robot(name)
    for k in ("a1", "d1", "a2", "a3", "d4", "d6"):
        assert getattr(kin, k) == pytest.approx(getattr(robot.kinematics, k), abs=1e-12)
    assert tuple(sign) == robot.controller_sign
    np.testing.assert_allclose(offset, robot.controller_offset_rad, atol=1e-12)


def test_a_robot_read_from_an_installed_packages_urdf_matches_that_urdf():
    """abb_irb4600_40_255 is read from compas_fab's URDF at run time: our FK of the derived robot puts the flange
    where MuJoCo puts the URDF's own link_6, for random axis values, and the flange frames differ by one constant
    rotation (the URDF's own choice of link_6 axes)."""
    pytest.importorskip("compas_fab")
    from dresspack_gym.io.loading import _model_file_path
    from dresspack_gym.robots.importer import load_model

    robot = load_robot("abb_irb4600_40_255")
    data = read_yaml(find_shipped("abb_irb4600_40_255", "robots", "robot"))
    m = load_model(_model_file_path(data["model_file"], find_shipped("abb_irb4600_40_255", "robots", "r").parent,
                                    "model_file"))
    d = mujoco.MjData(m)
    kin = RobotKinematics(robot)
    last = int(m.jnt_bodyid[m.njnt - 1])
    rel = None
    lim = kin.limits
    for q in np.random.default_rng(3).uniform(lim[:, 0], lim[:, 1], size=(100, 6)):
        d.qpos[:] = robot.to_controller(q)
        mujoco.mj_kinematics(m, d)
        ours = kin.flange(q)
        np.testing.assert_allclose(ours[:3, 3], d.xpos[last], atol=1e-4)  # the URDF rounds pi/2 to 1.57076
        r = ours[:3, :3].T @ d.xmat[last].reshape(3, 3)
        rel = r if rel is None else rel
        np.testing.assert_allclose(r, rel, atol=1e-4)
    assert robot.kinematics.d4 == pytest.approx(1.270) and robot.kinematics.a2 == pytest.approx(1.095)


@pytest.mark.parametrize("chain_edit,match", [
    (lambda c: c[:5], "exactly 6 revolute joints"),
    (lambda c: [c[0], ((0.35, 0.2, 0), c[1][1])] + c[2:], "sideways offset"),
    (lambda c: c[:4] + [((1.2, 0, 0.1), c[4][1])] + c[5:], "do not meet"),
    (lambda c: [((0, 0, 0.675), (1, 0, 0))] + c[1:], "j1 is not vertical"),
])
def test_arms_of_another_form_are_refused_with_the_reason(tmp_path, chain_edit, match):
    from dresspack_gym.robots.importer import derive, load_model

    (tmp_path / "m.urdf").write_text(_chain_urdf(chain_edit(list(MAKER_CHAINS["kuka_kr210_r2700_extra"]))))
    with pytest.raises(ConfigError, match=match):
        derive(load_model(tmp_path / "m.urdf"))


def test_model_file_yaml_errors_name_the_field(tmp_path):
    (tmp_path / "m.urdf").write_text(_chain_urdf(MAKER_CHAINS["kuka_kr210_r2700_extra"]))
    base = "name: x\nsource: y\ntool: {tcp_pos: [0.4, 0, 0]}\n"
    cases = [(base + "model_file: m.urdf\nkinematics: {a1: 1}\n", "x.yaml.kinematics"),
             (base + "model_file: {package: no_such_package_xyz, path: a.urdf}\n", "not installed"),
             (base + "model_file: missing.urdf\n", "file not found"),
             (base + "model_file: [1, 2]\n", "expected a file path")]
    for text, match in cases:
        (tmp_path / "x.yaml").write_text(text)
        with pytest.raises(ConfigError, match=match):
            load_robot(tmp_path / "x.yaml")
    (tmp_path / "x.yaml").write_text(base + "model_file: m.urdf\n")
    robot = load_robot(tmp_path / "x.yaml")
    assert robot.kinematics.d4 == pytest.approx(1.2) and robot.joint_speed == pytest.approx([2.0] * 6)


def test_robots_command_prints_the_round_trip_and_writes_the_models(tmp_path, capsys):
    import json

    from dresspack_gym.cli.main import main

    assert main(["robots", "fanuc_r2000ic_210f", "--poses", "40", "--json", "--export", str(tmp_path / "m")],
                extensions=[]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows[0]["robot"] == "fanuc_r2000ic_210f" and rows[0]["found_q"] and rows[0]["max_raw_branches"] == 8
    assert (tmp_path / "m" / "fanuc_r2000ic_210f.urdf").is_file()
    assert (tmp_path / "m" / "fanuc_r2000ic_210f.xml").is_file()


# ------------------------------------------------------------------------------ general arms: numeric IK
def _ur10e_yaml(tmp_path):
    pytest.importorskip("compas_fab")
    (tmp_path / "ur10e.yaml").write_text(
        "name: ur10e\nsource: compas_fab URDF\n"
        "model_file: {package: compas_fab, path: data/robot_library/ur10e_robot/urdf/robot_description.urdf}\n"
        "tool: {tcp_pos: [0, 0, 0.2]}\n")
    return load_robot(tmp_path / "ur10e.yaml")


def test_an_arm_without_a_spherical_wrist_becomes_a_joint_chain_solved_numerically(tmp_path):
    """A UR10e (offset wrist) read from compas_fab's URDF: a general chain whose numeric IK finds the sampled
    configuration every time, and whose flange is where MuJoCo puts the URDF's last link."""
    from dresspack_gym.io.loading import _model_file_path
    from dresspack_gym.robots.importer import load_model

    robot = _ur10e_yaml(tmp_path)
    assert robot.kinematics is None and robot.chain is not None
    r = ik_round_trip(robot, poses=25, seed=4)
    assert r.poses >= 22 and r.found_q and r.max_pose_error < 1e-9 and r.max_raw_branches == 8
    m = load_model(_model_file_path({"package": "compas_fab", "path": "data/robot_library/ur10e_robot/urdf/"
                                                                      "robot_description.urdf"}, tmp_path, "f"))
    d = mujoco.MjData(m)
    kin = RobotKinematics(robot)
    last = int(m.jnt_bodyid[m.njnt - 1])
    lim = kin.limits
    for q in np.random.default_rng(5).uniform(lim[:, 0], lim[:, 1], size=(50, 6)):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        np.testing.assert_allclose(kin.flange(q)[:3, 3], d.xpos[last], atol=1e-9)
        np.testing.assert_allclose(kin.flange(q)[:3, :3], d.xmat[last].reshape(3, 3), atol=1e-9)


def test_a_joint_chain_robot_builds_in_mujoco_as_its_kinematics(tmp_path):
    from dresspack_gym.robots.model import add_robot

    robot = _ur10e_yaml(tmp_path)
    spec = mujoco.MjSpec()
    add_robot(spec, "r1", robot, (0.5, -0.2, 0.1), 0.7)
    m = spec.compile()
    d = mujoco.MjData(m)
    kin = RobotKinematics(robot, (0.5, -0.2, 0.1), 0.7)
    lim = kin.limits
    for q in np.random.default_rng(6).uniform(lim[:, 0], lim[:, 1], size=(30, 6)):
        d.qpos[:6] = q
        mujoco.mj_kinematics(m, d)
        for i, frame in enumerate(kin.link_frames(q)[1:7], start=1):
            np.testing.assert_allclose(d.xpos[m.body(f"r1/link{i}").id], frame[:3, 3], atol=1e-9)
        tcp = kin.tcp_pose(q)
        np.testing.assert_allclose(d.site_xpos[m.site("r1/tcp").id], tcp[:3, 3], atol=1e-9)
        np.testing.assert_allclose(d.site_xmat[m.site("r1/tcp").id].reshape(3, 3), tcp[:3, :3], atol=1e-9)


def test_numeric_ik_finds_every_analytic_branch(tmp_path):
    """The spherical-wrist ABB IRB 6700 read as a general chain: for generic poses, the numeric IK's solutions are
    exactly the analytic IK's branches (eight where the wrist can also be reached from behind)."""
    from dresspack_gym.robots.importer import chain_from_model, load_model, to_urdf

    robot = load_robot("abb_irb6700_200_260")
    (tmp_path / "a.urdf").write_text(to_urdf(robot))
    chain, _ = chain_from_model(load_model(tmp_path / "a.urdf"))
    numeric = RobotKinematics(replace(robot, kinematics=None, chain=chain))
    analytic = RobotKinematics(robot)
    rng = np.random.default_rng(7)
    qs = np.vstack([[0.41, -0.69, -1.38, -1.45, 0.94, 1.24], rng.uniform(-1.2, 1.2, size=(5, 6))])
    counts = []
    for q in qs:
        target = analytic.flange(q)
        a = analytic.ik_flange(target, within_limits=False)
        n = numeric.ik_flange(target, within_limits=False)
        assert len(n) == len(a)
        for s in a:
            assert np.min(np.abs(np.angle(np.exp(1j * (n - s)))).max(axis=1)) < 1e-7
        counts.append(len(a))
    assert max(counts) == 8


def test_a_joint_chain_robot_round_trips_through_urdf_and_mjcf(tmp_path):
    from dresspack_gym.robots.importer import robot_from_model, to_mjcf, to_urdf

    robot = _ur10e_yaml(tmp_path)
    qs = np.random.default_rng(8).uniform(-3, 3, size=(20, 6))
    for suffix, text, tol in ((".urdf", to_urdf(robot), 1e-12), (".xml", to_mjcf(robot), 1e-5)):
        (tmp_path / f"w{suffix}").write_text(text)
        back = robot_from_model(robot, tmp_path / f"w{suffix}")
        assert back.chain is not None
        a, b = RobotKinematics(robot), RobotKinematics(back)
        for q in qs:
            np.testing.assert_allclose(b.tcp_pose(q), a.tcp_pose(q), atol=1e-8)
        np.testing.assert_allclose(back.joint_limits, robot.joint_limits, atol=tol)


def test_collision_from_model_uses_the_makers_meshes(tmp_path):
    """``collision: from_model`` puts the URDF's collision meshes on our links; the robot's distance to a ball
    placed 2 cm behind the arm's rearmost mesh vertex at Home is 2 cm (MuJoCo collides the meshes' convex hulls)."""
    pytest.importorskip("compas_fab")
    from dresspack_gym.stations.collision import RobotCollisionChecker
    from dresspack_gym.stations.config import Obstacle

    (tmp_path / "irb.yaml").write_text(
        "name: irb4600_meshes\nsource: compas_fab URDF\n"
        "model_file: {package: compas_fab, path: data/robot_library/abb_irb4600_40_255/urdf/robot_description.urdf}\n"
        "tool: {tcp_pos: [0.45, 0, 0], tcp_rpy_deg: [0, 90, 0]}\ncollision: from_model\n")
    robot = load_robot(tmp_path / "irb.yaml")
    assert {p.link for p in robot.collision} == {"base", "link1", "link2", "link3", "link4", "link5", "link6"}
    assert all(p.type == "mesh" for p in robot.collision)
    cfg = load_station("default")
    cfg = replace(cfg, robots=(replace(cfg.robots[0], robot=robot),), obstacles=(), weld_points=())
    station = Station(cfg)
    m, d = station.model, mujoco.MjData(station.model)
    d.qpos[station.robots[0].qpos] = station.home[0]
    mujoco.mj_kinematics(m, d)
    back = None
    for g in station.robots[0].geom_ids:
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:  # the dresspack's node markers
            continue
        mesh = m.geom_dataid[g]
        verts = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
        world = d.geom_xpos[g] + verts @ d.geom_xmat[g].reshape(3, 3).T
        v = world[np.argmin(world[:, 0])]
        back = v if back is None or v[0] < back[0] else back
    R = 0.05
    ball = Obstacle(name="ball", type="sphere", pos=(float(back[0] - 0.02 - R), float(back[1]), float(back[2])),
                    rpy=(0.0, 0.0, 0.0), size=(R,))
    station = Station(replace(cfg, obstacles=(ball,)))
    assert RobotCollisionChecker(station).min_distance(station.home[0]) == pytest.approx(0.02, abs=2e-4)


def test_swapped_urdf_limits_are_refused_naming_the_joint(tmp_path):
    """MuJoCo drops a limit whose lower end is above its upper end (the joint would turn a full turn either way):
    the URDF is refused, naming the joint."""
    limits = [(-3.0, 3.0)] * 6
    limits[1] = (1.0, -1.0)
    (tmp_path / "m.urdf").write_text(_chain_urdf(MAKER_CHAINS["kuka_kr210_r2700_extra"], limits))
    (tmp_path / "x.yaml").write_text("name: x\nsource: y\ntool: {tcp_pos: [0.4, 0, 0]}\nmodel_file: m.urdf\n")
    with pytest.raises(ConfigError, match="joint 'joint_2' has lower limit 1 > upper limit -1 rad"):
        load_robot(tmp_path / "x.yaml")


def test_xml_entities_are_refused_as_what_they_are(tmp_path):
    """Nested entity declarations (which expand without bound) are refused as such, not as a joint speed the
    expansion produced."""
    text = _chain_urdf(MAKER_CHAINS["kuka_kr210_r2700_extra"])
    entities = '<!DOCTYPE robot [<!ENTITY a "2"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>\n'
    (tmp_path / "m.urdf").write_text('<?xml version="1.0"?>\n' + entities + text.replace('velocity="2"',
                                                                                          'velocity="&b;"'))
    (tmp_path / "x.yaml").write_text("name: x\nsource: y\ntool: {tcp_pos: [0.4, 0, 0]}\nmodel_file: m.urdf\n")
    with pytest.raises(ConfigError) as err:
        load_robot(tmp_path / "x.yaml")
    assert "declares a document type or entities" in str(err.value) and "speed" not in str(err.value)
    (tmp_path / "m.urdf").write_text(text.replace("</robot>", "<link"))
    with pytest.raises(ConfigError, match="does not compile|not well-formed XML|MuJoCo can read"):
        load_robot(tmp_path / "x.yaml")
