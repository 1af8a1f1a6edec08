"""The report's videos: the same files on one process or a pool, drawn from kept positions or simulated again."""

from __future__ import annotations

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.station import Station


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_videos_are_the_same_files_on_one_process_or_two(tmp_path):
    pytest.importorskip("imageio.v2")
    from dresspack.eval.animations import Clip, render_clips

    from dresspack_gym.stations.rendering import StationRenderer

    station = Station(load_station("default"))
    try:
        StationRenderer(station.model, width=16, height=16).close()
    except Exception as exc:  # no offscreen GL on this machine
        if "rendering is unavailable" in str(exc):
            pytest.skip(str(exc))
        raise
    home = station.home[0]
    trajs = [Trajectory(np.stack([home, home + np.radians(d)]), (1,))
             for d in ([15, 0, 0, 0, 0, 0], [0, -10, 10, 0, 20, 0], [-15, 0, 0, 0, 0, 30])]
    kept = replay(CableSimulator(station), trajs[1], record_qpos=True)  # one clip drawn from kept positions

    def clips(folder):
        return [Clip(str(folder / f"{i}.mp4"), t.waypoints, t.stops, kept if i == 1 else None)
                for i, t in enumerate(trajs)]

    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    render_clips("default", 0, clips(tmp_path / "one"), jobs=1)
    render_clips("default", 0, clips(tmp_path / "two"), jobs=2)
    for i in range(len(trajs)):
        one, two = (tmp_path / "one" / f"{i}.mp4").read_bytes(), (tmp_path / "two" / f"{i}.mp4").read_bytes()
        assert len(one) > 1000 and one == two, f"video {i}"


def test_the_rod_engines_videos_draw_its_kept_points_and_refuse_another_engines_replay(tmp_path):
    pytest.importorskip("imageio.v2")
    from dresspack.eval.animations import Clip, render_clips

    from dresspack_gym.errors import ConfigError
    from dresspack_gym.physics.profiles import make_simulator
    from dresspack_gym.stations.rendering import StationRenderer

    station = Station(load_station("default"))
    try:
        StationRenderer(station.model, width=16, height=16).close()
    except Exception as exc:  # no offscreen GL on this machine
        if "rendering is unavailable" in str(exc):
            pytest.skip(str(exc))
        raise
    home = station.home[0]
    traj = Trajectory(np.stack([home, home + np.radians([0, -10, 10, 0, 20, 0])]), (1,))
    kept = replay(make_simulator(station, "fast"), traj, record_qpos=True)
    clip = Clip(str(tmp_path / "rod.mp4"), traj.waypoints, traj.stops, kept)
    render_clips("default", 0, [clip], engine="fast")
    assert (tmp_path / "rod.mp4").stat().st_size > 1000
    with pytest.raises(ConfigError, match="clips"):  # a rod replay stands for no MuJoCo video
        render_clips("default", 0, [clip], engine="dynamic")
    with pytest.raises(ConfigError, match="engine"):
        render_clips("default", 0, [clip], engine="quick")
