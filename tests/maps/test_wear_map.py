"""The settled-shape wear map, the dresspack's reach as a validity check, and the map as a state cost."""

from dataclasses import replace

import numpy as np
import pytest
from dresspack.agents.planners.map_roadmap import MapRoadmap, fine_wear, motion_time

from dresspack_gym.cable.shape import span_slack
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.maps.map_cost import OBSTRUCTION_DEPTH, OBSTRUCTION_RATE, UNSPANNABLE_RATE, MapStateCost
from dresspack_gym.maps.robustness.algorithm import cable_only
from dresspack_gym.maps.wear_map import WearMap, WearMapSettings, build_wear_map, map_key, sample_configurations
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, make_simulator
from dresspack_gym.stations.config import Obstacle
from dresspack_gym.stations.station import Station, node_frames
from dresspack_gym.stations.validity import MotionValidity


@pytest.fixture(scope="module")
def default_config():
    return load_station("default")


@pytest.fixture(scope="module")
def small_map(default_config):
    return build_wear_map(default_config, 0, WearMapSettings(samples=24, seed=3))


# ------------------------------------------------------------------------------ the dresspack's reach
def test_span_slack_is_cable_minus_chord_for_a_world_anchored_cable():
    config = load_station("thesis_tension")
    st = Station(config)
    p = config.robots[0]
    dp = p.dresspack
    for q in (st.home[0], np.radians([20, 30, 10, 0, 40, 0])):
        frames = node_frames(p, st.robots[0].kinematics.link_frames(q))
        # the inner clamp points: one edge in from each end along its clamp direction
        start = frames[0][:3, :3] @ np.array(dp.nodes[0].pos) + frames[0][:3, 3]
        start = start + frames[0][:3, :3] @ np.array(dp.nodes[0].direction) * dp.segment_length
        end = frames[1][:3, :3] @ np.array(dp.nodes[1].pos) + frames[1][:3, 3]
        end = end - frames[1][:3, :3] @ np.array(dp.nodes[1].direction) * dp.segment_length
        expected = (dp.segments - 2) * dp.segment_length - np.linalg.norm(end - start)
        assert span_slack(dp, frames) == pytest.approx(expected, abs=1e-12)


def test_validity_rejects_configurations_the_cable_cannot_reach():
    st = Station(load_station("thesis_tension"))
    v = MotionValidity(st)
    assert v._may_tear
    q_far = np.radians([180, 0, 0, 0, 0, 0])  # the tool behind the robot, 3 m from the node under the cuboid
    q_far[0] = np.clip(q_far[0], *v.limits[0])
    assert v.cable_slack(q_far) < 0
    assert not v.valid(q_far)
    assert "dresspack cannot reach" in v.why_invalid(q_far)
    assert not v.segment_valid(st.home[0], q_far)


def test_link3_to_link6_dresspack_can_never_tear_and_skips_the_check(default_config):
    """The bound through the wrist centre proves it; random configurations agree."""
    st = Station(default_config)
    v = MotionValidity(st)
    assert not v._may_tear
    p = default_config.robots[0]
    lim = p.robot.joint_limits
    qs = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], (300, 6))
    slack = [span_slack(p.dresspack, node_frames(p, st.robots[0].kinematics.link_frames(q))) for q in qs]
    assert min(slack) > 0


# ------------------------------------------------------------------------------ the map
@pytest.mark.parametrize("field, value", [("samples", 0), ("samples", 2.5), ("seed", -1), ("neighbours", 0),
                                          ("lever", 0.0), ("lever", "x")])
def test_bad_map_settings_name_the_field(field, value):
    with pytest.raises(ConfigError, match=f"wear_map.{field}"):
        WearMapSettings(**{field: value})


def test_map_key_ignores_obstacles_and_welds_but_not_the_dresspack(default_config):
    moved = replace(default_config, obstacles=default_config.obstacles[1:], weld_points=default_config.weld_points[:1])
    assert map_key(moved) == map_key(default_config)
    r = default_config.robots[0]
    longer = replace(default_config, robots=(replace(r, dresspack=replace(r.dresspack, length=1.8)),))
    assert map_key(longer) != map_key(default_config)


def test_map_key_ignores_what_the_map_does_not_depend_on(default_config):
    """Tool, speeds, collision geometry, controller conventions or the robot's name do not change a settled free
    cable; the kinematic chain and the joint limits (where samples are drawn) do."""
    p = default_config.robots[0]
    key = map_key(default_config)

    def with_robot(**changes):
        return replace(default_config, robots=(replace(p, robot=replace(p.robot, **changes)),))

    assert map_key(with_robot(name="x", tcp_pos=(0.1, 0.0, 0.0), joint_speed_rad_s=(1.0,) * 6, collision=(),
                              controller_sign=(-1.0,) * 6)) == key
    assert map_key(with_robot(kinematics=replace(p.robot.kinematics, d4=1.2))) != key
    assert map_key(with_robot(joint_limits_rad=((-1.0, 1.0),) * 6)) != key


def test_map_is_reproducible_and_exact_at_its_samples(default_config, small_map):
    again = build_wear_map(default_config, 0, WearMapSettings(samples=24, seed=3))
    assert np.array_equal(again.features, small_map.features)
    assert np.array_equal(again.deviation, small_map.deviation)
    assert small_map.info["settled"] == len(small_map) == 24  # a link 3 - link 6 cable spans everywhere
    # at a sample's own configuration the map returns that settle: re-settle independently and compare
    q = sample_configurations(default_config.robots[0].robot.joint_limits, small_map.settings)[5]
    assert small_map.info["engine"] == DEFAULT_ENGINE  # settled on the default engine unless told otherwise
    sim = make_simulator(Station(cable_only(default_config)), small_map.info["engine"])
    sim.reset(q[None], settle=False)
    assert sim.settle().converged  # the shape compared is an equilibrium, by its residual
    pred = small_map.predict(q)
    assert pred.reach < 1e-9
    np.testing.assert_allclose(pred.points, sim.cable_points(0), atol=1e-9)
    m = sim.measures()
    assert pred.max_curvature == pytest.approx(m.max_curvature)
    assert pred.max_tension == pytest.approx(m.max_tension)


def test_map_round_trips_through_a_file(default_config, small_map, tmp_path):
    path = small_map.save(tmp_path / "m.npz")
    loaded = WearMap.load(path, default_config)
    q = np.radians([10, 20, -10, 30, 40, -50])
    a, b = small_map.predict(q), loaded.predict(q)
    np.testing.assert_allclose(a.points, b.points, atol=1e-5)  # stored as float32
    r = default_config.robots[0]
    other = replace(default_config, robots=(replace(r, dresspack=replace(r.dresspack, length=1.8)),))
    with pytest.raises(ConfigError, match="wear_map"):
        WearMap.load(path, other)


@pytest.mark.slow  # a 300-sample wear map, then 12 held-out shapes settled (~30 s)
def test_map_predicts_held_out_shapes_better_than_the_reference_curve(default_config):
    """The interpolated deviation must carry real information: at configurations it never saw, the map's
    shape is nearer the settled one than the analytic curve through the same nodes."""
    wm = build_wear_map(default_config, 0, WearMapSettings(samples=300, seed=1))
    sim = make_simulator(Station(cable_only(default_config)), wm.info["engine"])
    lim = default_config.robots[0].robot.joint_limits
    err_map, err_ref = [], []
    for q in np.random.default_rng(99).uniform(lim[:, 0], lim[:, 1], (12, 6)):
        sim.reset(q[None], settle=False)
        assert sim.settle().converged  # the truth is an equilibrium, by its residual
        truth = sim.cable_points(0)
        pred = wm.predict(q)
        ref = wm.model.reference(wm.model.frames(q))
        err_map.append(np.linalg.norm(pred.points - truth, axis=1).max())
        err_ref.append(np.linalg.norm(ref - truth, axis=1).max())
    assert np.mean(err_map) < 0.8 * np.mean(err_ref)


# ------------------------------------------------------------------------------ the state cost
def _with_sphere(config, center, radius):
    ball = Obstacle(name="ball", type="sphere", pos=tuple(map(float, center)), rpy=(0.0, 0.0, 0.0), size=(radius,))
    return replace(config, obstacles=(ball,))


def _segment_distance(p, a, b):
    t = np.clip(np.einsum("ij,ij->i", p - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0.0, 1.0)
    return np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1)


def test_map_cost_clearance_and_obstruction_against_geometry(default_config, small_map):
    q = np.radians([0, 10, 10, 30, -40, 20])
    pts = small_map.predict(q).points
    r = default_config.robots[0].dresspack.radius
    # a ball centred on a vertex: the cable passes through it, depth R + r
    R = 0.05
    config = replace(_with_sphere(default_config, pts[12], R), wear_cost=replace(default_config.wear_cost,
                                                                                  w_distance=0.0))
    terms = MapStateCost(Station(config), small_map).terms(q)
    assert terms["obstruction"] == pytest.approx(OBSTRUCTION_RATE * ((R + r) / OBSTRUCTION_DEPTH) ** 2, rel=1e-6)
    # a ball 0.4 m above the cable's highest point: clearance = segment distance - R - r, term w_d (d - c)^2
    center = pts[np.argmax(pts[:, 2])] + np.array([0.0, 0.0, 0.4 + R])
    config = _with_sphere(default_config, center, R)
    cfg = config.wear_cost
    d = float(_segment_distance(np.repeat(center[None], len(pts) - 1, 0), pts[:-1], pts[1:]).min()) - R - r
    terms = MapStateCost(Station(config), small_map).terms(q)
    assert terms["obstruction"] == 0.0
    assert terms["distance"] == pytest.approx(cfg.w_distance * min(0.0, d - cfg.clearance) ** 2, rel=1e-6)


def test_a_plane_supports_the_predicted_cable_but_never_obstructs_it(default_config, small_map, monkeypatch):
    """A predicted shape sagging through a plane (the floor) would rest on it, not be caught by it: no obstruction
    term, clearance 0 for the distance term; a solid it passes through at the same time still obstructs."""
    monkeypatch.setattr("dresspack_gym.stations.station.check_station", lambda station: None)  # the raised floor cuts the base
    q = np.radians([0, 10, 10, 30, -40, 20])
    pts = small_map.predict(q).points
    r = default_config.robots[0].dresspack.radius
    floor = Obstacle(name="raised_floor", type="plane", pos=(0.0, 0.0, float(pts[:, 2].min()) + 0.1),
                     rpy=(0.0, 0.0, 0.0), size=(5.0, 5.0, 0.1))
    cfg = default_config.wear_cost
    terms = MapStateCost(Station(replace(default_config, obstacles=(floor,))), small_map).terms(q)
    assert terms["obstruction"] == 0.0
    assert terms["distance"] == pytest.approx(cfg.w_distance * cfg.clearance ** 2, rel=1e-9)
    R = 0.05
    config = _with_sphere(default_config, pts[12], R)
    config = replace(config, obstacles=config.obstacles + (floor,))
    terms = MapStateCost(Station(config), small_map).terms(q)
    assert terms["obstruction"] == pytest.approx(OBSTRUCTION_RATE * ((R + r) / OBSTRUCTION_DEPTH) ** 2, rel=1e-6)


def test_map_cost_of_an_unreachable_configuration():
    config = load_station("thesis_tension")
    wm = build_wear_map(config, 0, WearMapSettings(samples=60, seed=0))
    assert 0 < len(wm) < 60  # the world-anchored cable cannot span most of the joint space
    cost = MapStateCost(Station(config), wm)
    q_far = np.radians([170, 0, 0, 0, 0, 0])
    assert cost.terms(q_far) == {"unspannable": UNSPANNABLE_RATE}


# ------------------------------------------------------------------------------ routes over the map
def _objective(roadmap, route, weight):
    """∫(1 + weight C_map) dt of a route, every segment costed finely."""
    total = 0.0
    for a, b in zip(route[:-1], route[1:]):
        t = motion_time(a, b, roadmap.limits)
        total += t + weight * fine_wear(roadmap.cost, a, b, t)
    return total


@pytest.mark.slow  # about 15-20 s on 2 cores: the fast tier's time
def test_roadmap_route_is_valid_no_worse_than_direct_and_reproducible(default_config):
    st = Station(default_config)
    wm = build_wear_map(default_config, 0, WearMapSettings(samples=150, seed=2))
    validity = MotionValidity(st, 0, margin=0.005)
    limits = default_config.robots[0].robot.joint_motion_limits.at_speed(default_config.simulation.speed_fraction)
    cost = MapStateCost(st, wm)
    roadmap = MapRoadmap(wm, validity, cost, limits)
    assert 0 < len(roadmap.nodes) <= len(wm)
    a = st.home[0]
    b = a + np.radians([-30.0, 15.0, 0.0, -20.0, 10.0, -20.0])
    assert validity.valid(b) and validity.segment_valid(a, b)
    for weight in (0.0, 50.0):
        route = roadmap.route(a, b, weight)
        assert route is not None
        np.testing.assert_array_equal(route[0], a)
        np.testing.assert_array_equal(route[-1], b)
        assert validity.path_valid(route)
        # the direct motion is one of the roadmap's edges: the search may only do better
        assert _objective(roadmap, route, weight) <= _objective(roadmap, np.array([a, b]), weight) + 1e-9
    fresh = MapRoadmap(wm, MotionValidity(st, 0, margin=0.005), MapStateCost(st, wm), limits)
    first = fresh.route(a, b, 50.0)
    np.testing.assert_array_equal(first, roadmap.route(a, b, 50.0))
    # a plan starts afresh: what earlier searches learnt about edges cannot change a later route
    fresh.route(b, a + np.radians([20.0, -10.0, 5.0, 30.0, -20.0, 10.0]), 5.0)
    fresh.forget()
    assert not fresh.checked and not fresh.fine
    np.testing.assert_array_equal(fresh.route(a, b, 50.0), first)


def test_a_map_keeps_its_engine_and_mujoco_maps_their_key(default_config, tmp_path):
    """The engine is part of a map's key except MuJoCo's (the shipped maps settled on it keep theirs); a map loads
    under its own engine's key, and the default engine's shipped map is looked up before MuJoCo's."""
    from dresspack_gym.maps.wear_map import load_wear_map, shipped_map_path

    mujoco = build_wear_map(default_config, 0, WearMapSettings(samples=2, seed=0), engine="dynamic")
    assert mujoco.info["engine"] == "dynamic" and mujoco.info["key"] == map_key(default_config)
    assert map_key(default_config, 0, "fast") != map_key(default_config)
    for m in (mujoco, build_wear_map(default_config, 0, WearMapSettings(samples=2, seed=0), engine="fast")):
        assert WearMap.load(m.save(tmp_path / f"{m.info['engine']}.npz"), default_config).info["engine"] \
            == m.info["engine"]
    config = load_station("thesis_tension")  # ships a MuJoCo map only: still found
    assert not shipped_map_path(config, 0, "fast").is_file() and shipped_map_path(config, 0).is_file()
    assert load_wear_map(config, 0).info.get("engine", "dynamic") == "dynamic"


def test_wear_map_command_builds_a_loadable_map_and_names_bad_input(tmp_path, capsys):
    import json

    from dresspack_gym.cli.main import main

    out = tmp_path / "m.npz"
    assert main(["wear-map", "--station", "default", "--samples", "8", "--out", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["settled"] == 8 and info["path"] == str(out) and info["engine"] == "dynamic"
    assert main(["wear-map", "--station", "default", "--samples", "2", "--out", str(tmp_path / "mujoco.npz"),
                 "--physics", "dynamic", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["engine"] == "dynamic"
    assert len(WearMap.load(out, load_station("default"))) == 8
    assert main(["wear-map", "--station", "default", "--robot", "3", "--samples", "8", "--out", str(out)]) == 2
    assert "--robot" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:  # argparse rejects it before anything runs
        main(["wear-map", "--station", "default", "--samples", "0"])
    assert exit_info.value.code == 2 and "--samples" in capsys.readouterr().err


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_planner_uses_the_shipped_map_or_says_it_has_none():
    from dresspack.agents.planners.registry import make_planner

    with_map = make_planner("ompl-wear", Station(load_station("thesis_tension")))
    assert with_map.wear_map is not None and with_map.routes.roadmap is not None
    without = make_planner("ompl-wear", Station(load_station("thesis_distance")))
    assert without.wear_map is None and without.routes.roadmap is None
    with pytest.raises(ConfigError, match="wear_map"):
        make_planner("ompl-wear", Station(load_station("thesis_distance")), wear_map="/nonexistent.npz")
