"""Videos drawn from a replay's kept positions: the same pictures as the live simulation, no second simulation."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.station import Station


@pytest.fixture(scope="module")
def station():
    return Station(load_station("default"))


def _renderer(station, **kwargs):
    from dresspack_gym.stations.rendering import StationRenderer

    try:
        return StationRenderer(station.model, **kwargs)
    except Exception as exc:  # no offscreen GL on this machine
        if "rendering is unavailable" in str(exc):
            pytest.skip(str(exc))
        raise


def _trajectory(station) -> Trajectory:
    home = station.home[0]
    return Trajectory(np.stack([home, home + np.radians([25, 0, 0, 0, 0, 0]),
                                home + np.radians([25, -10, 10, 0, 30, 0])]), (1, 2))


def test_kept_positions_draw_what_the_live_simulation_showed_and_change_no_measure(station):
    traj = _trajectory(station)
    renderer = _renderer(station, width=160, height=96, shadows=False)
    sim = CableSimulator(station)
    live = []
    scratch = mujoco.MjData(station.model)

    def picture(t: float) -> None:  # the live state at the sample (its positions, not a step's start, as measured)
        mujoco.mj_copyData(scratch, station.model, sim.data)
        mujoco.mj_forward(station.model, scratch)
        live.append((t, renderer.render(scratch)))

    rep = replay(sim, traj, record_every=0.1, record_qpos=True, on_sample=picture)
    plain = replay(CableSimulator(station), traj, record_every=0.1)
    assert rep.qpos.shape == (len(rep.time), station.model.nq) and plain.qpos is None
    for name, values in plain.measures.items():  # keeping positions disturbs nothing
        np.testing.assert_array_equal(rep.measures[name], values, err_msg=name)
    # the live pictures are those of the motion samples (a weld's settled sample repeats its time: not called back)
    firsts = [i for i in range(len(rep.time)) if i == 0 or rep.time[i] > rep.time[i - 1]]
    assert [t for t, _ in live] == pytest.approx(rep.time[firsts].tolist(), abs=1e-12)
    data = mujoco.MjData(station.model)
    for (t, picture), i in zip(live, firsts):
        data.qpos[:] = rep.qpos[i]
        mujoco.mj_forward(station.model, data)
        np.testing.assert_array_equal(renderer.render(data), picture, err_msg=f"t = {t}")
    settled = [i for i in range(1, len(rep.time)) if rep.time[i] == rep.time[i - 1]]
    assert len(settled) == 2 and all(np.abs(rep.qpos[i] - rep.qpos[i - 1]).max() > 0 for i in settled)
    renderer.close()


def test_a_video_from_kept_positions_simulates_nothing_and_shows_the_motion_at_its_rate(station, tmp_path,
                                                                                       monkeypatch):
    imageio = pytest.importorskip("imageio.v2")
    import dresspack_gym.io.animation as animation

    _renderer(station, width=16, height=16).close()
    traj = _trajectory(station)
    rep = replay(CableSimulator(station), traj, record_every=0.05, record_qpos=True)

    def no_replay(*args, **kwargs):
        raise AssertionError("the video simulated again")

    monkeypatch.setattr(animation, "replay", no_replay)
    fps = 10.0
    result = animation.animate(CableSimulator(station), traj, tmp_path / "a.mp4", fps=fps, width=160, height=96,
                               strip_height=60, measured=rep)
    frames = [f for f in imageio.get_reader(tmp_path / "a.mp4")]  # list() asks the reader its length: inf
    assert len(frames) == result["frames"]
    # one frame per 1/fps s of motion on the replay's grid: the video lasts about as long as the motion
    assert abs(result["duration_s"] - rep.time[-1]) <= 2.0 / fps + 0.05 * rep.time[-1]
    coarse = replay(CableSimulator(station), traj, record_every=0.2, record_qpos=True)
    assert animation.frame_samples(coarse, fps) is None  # a grid coarser than the video's: simulated again
