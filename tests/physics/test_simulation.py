"""Quasi-static simulation: path dependence, determinism, state save/restore, clear motion errors."""

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station

D = np.radians
TARGET = D([8, 6, -8, 247, -90, 319])
VIA = D([8, 26, -8, 300, 10, 360])  # a large wrist excursion before reaching the same TARGET


@pytest.fixture(scope="module")
def sim():
    return CableSimulator(Station(load_station("default")))


def test_same_configuration_by_two_paths_gives_different_shapes(sim):
    home = sim.get_state()
    sim.move_to(TARGET)
    direct = sim.cable_points()
    sim.set_state(home)
    sim.move_to(VIA, settle=False)
    sim.move_to(TARGET)
    detour = sim.cable_points()
    np.testing.assert_allclose(sim.q[0], TARGET)
    assert np.linalg.norm(direct - detour, axis=1).max() > 0.1  # metres: a different equilibrium


def test_repeating_the_same_path_gives_the_same_shape(sim):
    home = sim.get_state()
    runs = []
    for _ in range(2):
        sim.set_state(home)
        sim.move_to(VIA, settle=False)
        sim.move_to(TARGET)
        runs.append((sim.cable_points(), sim.measures()))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    assert runs[0][1] == runs[1][1]


def test_state_restore_includes_der_reference_frames(sim):
    sim.reset()
    sim.move_to(VIA, settle=False)
    mid = sim.get_state()
    plastic = sim.data.plastic.copy()
    sim.move_to(TARGET)
    expected = sim.cable_points()
    sim.reset()  # wipes the plastic reference frames
    assert not np.array_equal(sim.data.plastic, plastic)
    sim.set_state(mid)
    np.testing.assert_array_equal(sim.data.plastic, plastic)
    sim.move_to(TARGET)
    np.testing.assert_array_equal(sim.cable_points(), expected)


def test_motion_respects_joint_speed_limits(sim):
    sim.reset()
    robot = sim.station.config.robots[0].robot
    trace = sim.move_to(TARGET, record_every=0.02, settle=False)
    q = np.array(trace.q)[:, 0]
    t = np.array(trace.time)
    speed = np.abs(np.diff(q, axis=0)) / np.diff(t)[:, None]
    assert np.all(speed <= robot.joint_speed * sim.config.speed_fraction * 1.0001)
    assert sim.motion_time == pytest.approx(t[-1], abs=1e-9)


def test_cable_follows_the_tool_support(sim):
    sim.reset()
    sim.move_to(TARGET)
    rob = sim.station.robots[0]
    frames = rob.kinematics.link_frames(sim.q[0])
    node = sim.station.config.robots[0].dresspack.nodes[-1]
    support = frames[6][:3, :3] @ np.asarray(node.pos) + frames[6][:3, 3]
    np.testing.assert_allclose(sim.cable_points()[-1], support, atol=2e-3)


@pytest.mark.parametrize("q, field", [
    (np.zeros(5), "q_target"),
    (np.array([0, 0, 0, 0, 0, np.nan]), "q_target"),
    (D([0, 100, 0, 0, 0, 0]), "q_target[1]"),  # j2 limit is 85 deg
])
def test_bad_motion_targets_name_the_field(sim, q, field):
    with pytest.raises(ConfigError) as err:
        sim.move_to(q)
    assert err.value.field == field


def test_bad_speed_fraction(sim):
    with pytest.raises(ConfigError, match="speed_fraction"):
        sim.move_to(TARGET, speed_fraction=0.0)


def test_measures_are_finite_along_a_motion(sim):
    sim.reset()
    trace = sim.move_to(VIA, record_every=0.1)
    assert len(trace.measures) > 5
    for m in trace.measures:
        values = [m.max_curvature, m.max_tension, m.min_clearance, m.max_twist_rate]
        assert all(np.isfinite(values)) and all(v >= 0 for v in values)


def test_two_robot_station_moves_both_and_reports_the_worst_cable():
    from helpers import default_station_dict

    from dresspack_gym.io.loading import station_from_dict

    d = default_station_dict()
    second = dict(d["robots"][0], name="r2", base_pos=[4.5, 0.0, 0.0], base_yaw_deg=180)
    d["robots"].append(second)
    d["weld_points"].append({"name": "far_side", "robot": "r2", "pos": [2.85, 0.6, 0.675], "approach": [-0.3, 0, -1]})
    station = Station(station_from_dict(d))
    assert station.n_robots == 2 and len(station.cables) == 2
    from dresspack_gym.stations.tasks import allowed_weld_configurations

    assert len(allowed_weld_configurations(station, 0, "far_side")) > 0
    sim = CableSimulator(station)
    target = station.home.copy()
    target[0, 0] += np.radians(20)
    target[1, 0] -= np.radians(20)
    sim.move_to(target)
    np.testing.assert_allclose(sim.q, target)
    per_cable = sim.cable_measures()
    worst = sim.measures()
    assert worst.max_curvature == max(m.max_curvature for m in per_cable)
    assert worst.min_clearance == min(m.min_clearance for m in per_cable)
    # each cable follows its own robot's tool support
    for i, rob in enumerate(station.robots):
        frames = rob.kinematics.link_frames(sim.q[i])
        node = station.config.robots[i].dresspack.nodes[-1]
        support = frames[6][:3, :3] @ np.asarray(node.pos) + frames[6][:3, 3]
        np.testing.assert_allclose(sim.cable_points(i)[-1], support, atol=2e-3)
