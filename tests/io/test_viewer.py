"""`dresspack view`: without a display one line that names the file-writing command; the replay, the cable's colours
by segment wear cost and the play/pause/scrub keys, all headless."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from dresspack_gym.cli.main import main
from dresspack_gym.io import viewer
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, save_trajectory
from dresspack_gym.physics.wear_cost import wear_cost
from dresspack_gym.stations.station import Station


@pytest.fixture(scope="module")
def station():
    return Station(load_station("default"))


def _trajectory(station) -> Trajectory:
    home = station.home[0]
    return Trajectory(np.stack([home, home + np.radians([25, 0, 0, 0, 0, 0]),
                                home + np.radians([25, -10, 10, 0, 30, 0])]), (1, 2))


@pytest.fixture
def no_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)


def test_without_a_display_view_says_so_in_one_line_and_names_the_command_that_writes_a_file(
        station, no_display, tmp_path, capsys):
    plan = tmp_path / "plan.npz"
    save_trajectory(plan, _trajectory(station), station="default", robot="r1", speed_fraction=0.5)
    assert main(["view", str(plan)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "no display" in lines[0] and f"dresspack animate {plan} --out" in lines[0], lines
    assert main(["view", "--station", "default"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "no display" in lines[0] and "dresspack render --station default" in lines[0]
    assert main(["view", "--station", "default", "--robot", "3"]) == 2  # bad input first, named
    assert "--robot" in capsys.readouterr().err


def test_the_segment_costs_at_home_reach_the_configurations_curvature_and_distance_terms_and_never_exceed_c(
        station):
    sim = CableSimulator(station)
    frames = viewer.record_frames(sim, None)
    cost = wear_cost(sim.measures(), station.config.wear_cost)
    assert frames.cost.shape == (1, station.cables[0].n_vertices) and frames.time.tolist() == [0.0]
    # each term of C is its worst segment's: no segment costs more than C, the worst one at least its largest term
    assert frames.cost.max() <= cost.total + 1e-9
    assert frames.cost.max() >= max(cost.curvature, cost.distance) - 1e-9
    assert frames.scale == frames.cost.max()
    np.testing.assert_allclose(frames.points[0], sim.cable_points(0))


def test_the_replay_frames_follow_the_motion_and_show_each_settled_stop(station):
    sim = CableSimulator(station)
    traj = _trajectory(station)
    frames = viewer.record_frames(sim, traj, fps=10.0)
    n = len(frames.time)
    assert frames.qpos.shape[0] == frames.points.shape[0] == frames.cost.shape[0] == n
    assert np.all(np.diff(frames.time) >= 0) and frames.time[-1] > 0.5
    stops = [i for i in range(1, n) if frames.time[i] == frames.time[i - 1]]
    assert len(stops) == 2  # the settle at each of the two stops: same time, a new shape
    assert all(np.abs(frames.points[i] - frames.points[i - 1]).max() > 0 for i in stops)
    assert np.ptp(frames.cost.max(axis=1)) > 0  # the cost changes as the cable moves
    playback = viewer.Playback(frames.time)
    playback._seek(frames.time[stops[0]])
    assert playback.index == stops[0]  # a stop's time shows its settled shape, the last sample at that time


def test_colours_run_from_blue_at_no_cost_to_red_at_the_scale_and_the_capsules_follow_the_cable(station):
    rgba = viewer.colours(np.array([0.0, 0.5, 1.0, 7.0]), 1.0)
    np.testing.assert_allclose(rgba[:, :3], viewer.RAMP[[0, 1, 2, 2]])
    assert np.all(rgba[:, 3] == 1.0)
    points = np.array([[0.0, 0, 1], [0.1, 0, 1], [0.2, 0, 1.1]])
    scene = mujoco.MjvScene(station.model, maxgeom=10)
    viewer.draw_cable(scene, points, np.array([0.0, 0.0, 2.0]), 2.0, 0.02)
    assert scene.ngeom == 2
    geoms = [scene.geoms[i] for i in range(2)]
    assert all(g.type == mujoco.mjtGeom.mjGEOM_CAPSULE for g in geoms)
    np.testing.assert_allclose(geoms[0].pos, [0.05, 0, 1], atol=1e-6)
    np.testing.assert_allclose(geoms[1].size[[0, 2]], [0.02, np.linalg.norm(points[2] - points[1]) / 2], rtol=1e-5)
    np.testing.assert_allclose(geoms[0].rgba[:3], viewer.RAMP[0], atol=1e-6)  # both ends cost nothing
    np.testing.assert_allclose(geoms[1].rgba[:3], viewer.RAMP[2], atol=1e-6)  # the costlier end: the scale


def test_play_pause_step_scrub_and_speed_keys():
    p = viewer.Playback(np.array([0.0, 0.5, 1.0, 1.0, 1.5, 2.0]))
    assert p.playing and p.advance(0.6) == 1
    p.key(viewer.KEY_SPACE)  # pause: the clock stands
    assert not p.playing and p.advance(5.0) == 1
    p.key(viewer.KEY_RIGHT)
    p.key(viewer.KEY_RIGHT)
    assert p.index == 3 and p.clock == 1.0
    p.key(viewer.KEY_LEFT)
    assert p.index == 2 and not p.playing
    p.key(viewer.KEY_PAGE_DOWN)  # one second on
    assert p.clock == 2.0 and p.index == 5
    p.key(viewer.KEY_HOME)
    assert p.index == 0
    p.key(viewer.KEY_UP)
    p.key(viewer.KEY_SPACE)
    assert p.speed == 2.0 and p.advance(0.5) == 3  # at twice the speed 0.5 s shows t = 1, the settled shape
    assert p.advance(10.0) == 5 and not p.playing  # pauses at the end
    p.key(viewer.KEY_SPACE)  # play again: from the start
    assert p.playing and p.index == 0
    for _ in range(10):
        p.key(viewer.KEY_DOWN)
    assert p.speed == viewer.SPEEDS[0]
    p.key(viewer.KEY_END)
    assert p.index == 5


def test_opened_at_a_time_the_playback_stands_paused_on_that_frame():
    p = viewer.Playback(np.array([0.0, 0.5, 1.0, 1.0, 1.5]), at=1.2)
    assert not p.playing and p.index == 3 and p.advance(1.0) == 3
    assert viewer.Playback(np.array([0.0, 0.5]), at=9.0).index == 1  # past the end: the last frame
