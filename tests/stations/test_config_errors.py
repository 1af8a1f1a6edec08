"""Bad input gives a ConfigError naming the field: YAML keys, types, units, reachability, cable length."""

import copy

import pytest
from helpers import THESIS_CABLE, default_station_dict

from dresspack_gym import ConfigError
from dresspack_gym.cable.config import DresspackConfig
from dresspack_gym.io.loading import load_robot, load_station, read_yaml, station_from_dict
from dresspack_gym.robots.config import RobotConfig
from dresspack_gym.stations.config import WearCostConfig
from dresspack_gym.stations.station import Station


def cable(**changes):
    d = copy.deepcopy(THESIS_CABLE)
    d["nodes"] = [{"name": "a", "body": "world", "pos": [0, 0, 2], "direction": [1, 0, 0]}]
    d.update(changes)
    return d


def station_with(**changes):
    d = default_station_dict()
    d.update(changes)
    return d


def expect_field(fn, field, match=None):
    with pytest.raises(ConfigError) as err:
        fn()
    assert err.value.field == field, str(err.value)
    if match:
        assert match in str(err.value)
    return err.value


def test_unknown_key_is_named_with_allowed_keys():
    e = expect_field(lambda: DresspackConfig.from_dict(cable(lenght=1.0)), "dresspack.lenght")
    assert "length" in str(e)


def test_length_in_millimetres_is_caught():
    expect_field(lambda: DresspackConfig.from_dict(cable(length=1740)), "dresspack.length", "metres")


def test_wrong_type():
    expect_field(lambda: DresspackConfig.from_dict(cable(radius="thick")), "dresspack.radius")


def test_missing_required_field():
    d = cable()
    del d["bending_stiffness"]
    expect_field(lambda: DresspackConfig.from_dict(d), "dresspack.bending_stiffness", "required")


def test_unknown_node_body_lists_allowed_values():
    d = cable(nodes=[{"name": "a", "body": "link9", "pos": [0, 0, 0]}])
    e = expect_field(lambda: DresspackConfig.from_dict(d), "dresspack.nodes[0].body")
    assert "link3" in str(e)


def test_nodes_must_increase_along_the_cable():
    d = cable(nodes=[{"name": "a", "body": "world", "pos": [0, 0, 2]},
                     {"name": "b", "body": "world", "pos": [1, 0, 2], "at": 1.0},
                     {"name": "c", "body": "world", "pos": [2, 0, 2], "at": 0.5}])
    expect_field(lambda: DresspackConfig.from_dict(d), "dresspack.nodes")


def test_robot_kinematics_in_millimetres_is_caught():
    data = read_yaml(__import__("dresspack_gym.io.loading", fromlist=["CONFIG_DIR"]).CONFIG_DIR
                     / "robots" / "abb_irb6700_200_260.yaml")
    data["kinematics"]["a2"] = 1125
    expect_field(lambda: RobotConfig.from_dict(data), "robot.kinematics.a2", "metres")


def test_joint_limit_order():
    data = read_yaml(__import__("dresspack_gym.io.loading", fromlist=["CONFIG_DIR"]).CONFIG_DIR
                     / "robots" / "abb_irb6700_200_260.yaml")
    data["joint_limits_deg"][2] = [70, -180]
    expect_field(lambda: RobotConfig.from_dict(data), "robot.joint_limits_deg[2]")


def test_unknown_robot_and_station_names_list_the_shipped_ones():
    e = expect_field(lambda: load_robot("kuka_kr_9000"), "robot")
    assert "abb_irb6700_200_260" in str(e)
    e = expect_field(lambda: load_station("no_such_station"), "station")
    assert "default" in str(e)


def test_unreachable_weld_point_is_named_by_the_task_that_uses_it():
    """A station with one unreachable weld still loads (tasks on its other welds run); a task using it fails
    naming the weld and the reason."""
    from dresspack_gym.stations.tasks import make_task

    d = default_station_dict()
    d["weld_points"].append({"name": "far", "pos": [6.0, 0.0, 1.0], "approach": [0, 0, -1]})
    station = Station(station_from_dict(d))
    assert "far" in station.unreachable_welds and len(station.weld_configurations["far"]) == 0
    task = make_task(station, 0, None, ["sill_front"])
    assert task.weld_names == ("sill_front",)
    e = expect_field(lambda: make_task(station, 0, None, ["sill_front", "far"]), "weld_points.far")
    assert "not reachable" in str(e)


def test_cable_shorter_than_its_nodes_demand():
    d = default_station_dict()
    d["robots"][0]["dresspack_overrides"] = {"length": 0.8}
    e = expect_field(lambda: Station(station_from_dict(d)), "robots[0].dresspack.length")
    assert "too short" in str(e)


def test_home_outside_joint_limits():
    d = default_station_dict()
    d["robots"][0]["home_deg"] = [0, 0, 0, 0, 140, 0]
    expect_field(lambda: station_from_dict(d), "robots[0].home_deg[4]")


def test_unknown_obstacle_type_and_duplicate_names():
    d = station_with(obstacles=[{"name": "x", "type": "cone", "pos": [1, 1, 1]}])
    e = expect_field(lambda: station_from_dict(d), "obstacles[0].type")
    assert "box" in str(e)
    box = {"name": "x", "type": "box", "pos": [3, 3, 1], "half_size": [0.1, 0.1, 0.1]}
    expect_field(lambda: station_from_dict(station_with(obstacles=[box, box])), "obstacles[1].name")


def test_unknown_top_level_key():
    expect_field(lambda: station_from_dict(station_with(wear_costs={})), "wear_costs")


def test_wear_cost_negative_weight():
    expect_field(lambda: WearCostConfig.from_dict({"w_tension": -1.0}), "wear_cost.w_tension")


def test_simulation_timestep_range():
    expect_field(lambda: station_from_dict(station_with(simulation={"timestep": 0.5})), "simulation.timestep")


def test_not_yaml_mapping(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("- just\n- a list\n")
    expect_field(lambda: load_station(p), "station")


def test_home_violating_a_restriction_is_rejected():
    d = default_station_dict()
    d["robots"][0]["restrictions"] = [{"type": "twist_sum", "upper_deg": 0}]
    e = expect_field(lambda: station_from_dict(d), "robots[0].home_deg")
    assert "j4 + j6" in str(e)


def test_allowed_weld_configurations_respect_restrictions():
    from dresspack_gym.stations.tasks import allowed_weld_configurations

    station = Station(load_station("default"))
    for name in station.weld_configurations:
        sols = allowed_weld_configurations(station, 0, name)
        assert len(sols) > 0
        assert station.config.robots[0].restrictions.allowed(sols).all()
        assert len(sols) <= len(station.weld_configurations[name])
