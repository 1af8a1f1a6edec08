"""The rod engine on a station: the same settled cable as MuJoCo at Home, and a weld cycle measured alike."""

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.rod.contact.report import contact_report
from dresspack_gym.rod.simulator import RodSimulator
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import select_weld_goals
from dresspack_gym.stations.validity import MotionValidity


def station_at(segments):
    cfg = load_station("default")
    robots = tuple(replace(r, dresspack=replace(r.dresspack, segments=segments)) for r in cfg.robots)
    return Station(replace(cfg, robots=robots))


@pytest.mark.parametrize("segments", [24, 48])
def test_home_equilibrium_matches_mujoco(segments):
    station = station_at(segments)
    fast, dynamic = RodSimulator(station), CableSimulator(station)
    assert fast.last_settle.converged and dynamic.last_settle.converged
    gap = np.linalg.norm(fast.cable_points() - dynamic.cable_points(), axis=1).max()
    assert gap < 2e-3  # both converged to their residual tolerance
    assert fast.rods[0].twists() == pytest.approx([0.0], abs=1e-9)  # installed untwisted at Home
    fm, dm = fast.measures(), dynamic.measures()
    assert fm.max_curvature == pytest.approx(dm.max_curvature, rel=0.03)
    assert fm.max_tension == pytest.approx(dm.max_tension, rel=0.01)
    # what the clamps carry: force and torque about the node point, as MuJoCo's load cells read them
    assert fm.max_node_force == pytest.approx(dm.max_node_force, rel=0.01)
    assert fm.max_node_torque == pytest.approx(dm.max_node_torque, rel=0.01)
    # the worst segment's damage rate (the damage cost variant's C), from the engine's own segment states
    assert fm.max_damage_rate == pytest.approx(dm.max_damage_rate, rel=0.01) and fm.damage_at == dm.damage_at


def test_scene_holds_every_obstacle_and_link_and_measures_clearance_as_mujoco():
    station = station_at(24)
    fast = RodSimulator(station)
    scene = fast.scenes[0]
    assert scene.n_obstacles == len(station.obstacle_geoms) and not scene.skipped
    assert len(scene.kind) == scene.n_obstacles + 7  # the robot's base and six links (the dresspack touches them)
    # the same shape in both clearance measures: the contact kernels' gaps against MuJoCo's narrow phase
    dynamic = CableSimulator(station)
    points = fast.cable_points()
    expected = dynamic.probe.min_distance(station.data_at_home(), station.cables[0], points)
    got = fast.measures()
    assert got.min_clearance == pytest.approx(expected[0], abs=1e-6)
    assert got.nearest_obstacle == expected[2]


def test_weld_cycle_runs_and_rests():
    station = station_at(24)
    sim = RodSimulator(station)
    # a wrist that turns the tool support less than the arm's girth: the cable is not wound onto the forearm (the
    # direct Home -> sill_front motion winds it there, and MuJoCo's settle jams on it)
    weld = station.weld_configurations["roof_rail_top"][1]
    trace = sim.move_to(weld, record_every=0.05)
    assert sim.last_settle.converged and sim.unconverged_steps == 0 and sim.jammed_samples == 0
    assert len(trace.measures) > 10 and all(np.isfinite(m.max_tension) for m in trace.measures)
    settled = sim.cable_points()
    sim.hold(5.0)  # rest stays rest (the settle's residual, 0.5 % of a weight, relaxes by micrometres)
    assert np.abs(sim.cable_points() - settled).max() < 1e-4


def test_the_cable_resting_on_the_roof_rail_stays_put():
    """floor_pan_inner: the cable comes to rest on the roof rail (MuJoCo's soft contact lets it slide on there and
    flags that settle unconverged, tests/physics/test_rest.py); on the rod engine the settle converges and 20 s more
    of motion steps with the robot still move no vertex 0.1 mm."""
    station = Station(load_station("default"))
    q = select_weld_goals(station, 0, MotionValidity(station, 0, 0.005).checker.collides,
                          ["floor_pan_inner"])["floor_pan_inner"]
    sim = RodSimulator(station)
    sim.move_to(q)
    assert sim.last_settle.converged and sim.unconverged_steps == 0
    rod, scene = sim.rods[0], sim.scenes[0]
    p, c = rod.primitives, rod.contact
    normal, _, gaps, nearest = contact_report(rod.x, rod.x, rod.radius, p.kind, p.pos, p.rot, p.size, p.pos, p.rot,
                                              p.mask, c.activation, c.stiffness, c.friction, c.slip)
    rail = scene.obstacle_names.index("roof_rail_near")
    assert (nearest[gaps < c.activation] == rail).any() and normal.sum() > 1.0  # it lies on the rail
    before, tension = sim.cable_points(), sim.measures().max_tension
    sim.hold(20.0)
    assert sim.unconverged_steps == 0
    assert np.linalg.norm(sim.cable_points() - before, axis=1).max() < 1e-4
    assert sim.measures().max_tension == pytest.approx(tension, rel=1e-3)


@pytest.mark.parametrize("name", ["default", "side_framing_4r"])
def test_targets_from_mujoco_kinematics_match_the_robot_kinematics(name):
    """The held vertices and clamp directors read off MuJoCo's kinematics pass (with the primitives) are those of
    the robots' own forward kinematics."""
    station = Station(load_station(name))
    sim = RodSimulator(station)
    rng = np.random.default_rng(1)
    for cable, scene in zip(sim.cables, sim.scenes):
        for _ in range(4):
            q = station.home + rng.normal(scale=0.4, size=station.home.shape)
            scene.at(q)
            pos, dirs = scene.targets()
            want_pos, want_dirs = cable.targets(station.robots[cable.robot].kinematics.link_frames(q[cable.robot]))
            np.testing.assert_allclose(pos, want_pos, atol=1e-9)
            np.testing.assert_allclose(dirs, want_dirs, atol=1e-9)
