"""Pictures of the rod engine: its replays keep the robots' positions and the cables' points, and the renderer draws
those cables where MuJoCo draws its own (videos, worst-moment pictures)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from dresspack_gym.cable.model import CABLE_RGBA
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import make_simulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.rendering import CablePoints, default_camera, live_frame, replay_frame
from dresspack_gym.stations.station import Station

NO_CABLES = CablePoints((), ())  # hides MuJoCo's cables and draws none: the picture without any cable


@pytest.fixture(scope="module")
def station():
    return Station(load_station("default"))


@pytest.fixture(scope="module")
def fast(station):
    return make_simulator(station, "fast")


@pytest.fixture(scope="module")
def renderer(station):
    from dresspack_gym.stations.rendering import StationRenderer

    try:
        r = StationRenderer(station.model, width=240, height=180, shadows=False)
    except Exception as exc:  # no offscreen GL on this machine
        if "rendering is unavailable" in str(exc):
            pytest.skip(str(exc))
        raise
    yield r
    r.close()


def _trajectory(station) -> Trajectory:
    home = station.home[0]
    return Trajectory(np.stack([home, home + np.radians([20, 0, 0, 0, 0, 0]),
                                home + np.radians([20, -10, 10, 0, 25, 0])]), (1, 2))


def _cable_mask(renderer, data, cables=None, camera=None) -> np.ndarray:
    """The pixels the cable covers: where the picture differs from the same one without any cable."""
    shown = renderer.render(data, camera, cables=cables).astype(int)
    bare = renderer.render(data, camera, cables=NO_CABLES).astype(int)
    return np.abs(shown - bare).sum(axis=-1) > 30


def test_a_rod_replay_keeps_the_robots_and_every_cables_points_and_measures_alike(station, fast):
    traj = _trajectory(station)
    rep = replay(fast, traj, record_every=0.1, record_qpos=True)
    plain = replay(fast, traj, record_every=0.1)
    n = len(rep.time)
    assert rep.engine == "fast" and rep.qpos.shape == (n, station.model.nq) and plain.cables is None
    assert len(rep.cables) == station.n_robots and rep.cables[0].shape == (n, station.cables[0].n_vertices, 3)
    for name, values in plain.measures.items():  # keeping positions disturbs nothing
        np.testing.assert_array_equal(rep.measures[name], values, err_msg=name)
    np.testing.assert_array_equal(rep.cables[0][-1], fast.cable_points(0))  # the end: where the simulator stands
    np.testing.assert_array_equal(rep.qpos[:, station.robot_qpos], rep.q)  # one robot: its joints are q
    # the robots' positions pose the nodes where the rod holds its clamped vertices
    data = mujoco.MjData(station.model)
    replay_frame(station, rep, n - 1, data)
    held = station.cables[0].attachments[0]
    node = data.xpos[station.model.body(held.body).id]
    assert np.linalg.norm(rep.cables[0][-1][list(held.vertices)] - node, axis=1).min() < 1e-6
    dynamic = replay(make_simulator(station, "dynamic"), traj, record_every=0.1, record_qpos=True)
    assert dynamic.cables is None and dynamic.qpos.shape == (len(dynamic.time), station.model.nq)


def test_the_rod_cable_is_drawn_where_mujocos_cable_is_at_home(station, fast, renderer):
    fast.reset()
    data, cables = live_frame(fast)
    assert isinstance(cables, CablePoints) and cables.radii == (station.cables[0].radius,)
    close = default_camera(station.model, distance=1.6, lookat=cables.points[0].mean(axis=0))
    rod = _cable_mask(renderer, data, cables, close)
    mj = make_simulator(station, "dynamic")
    muj = _cable_mask(renderer, mj.data, camera=close)
    # both settled at Home: the same cable, seen alike (the rod engine's sag is within a few mm of MuJoCo's)
    assert rod.sum() > 1000 and muj.sum() > 1000
    assert (rod & muj).sum() / (rod | muj).sum() > 0.8
    # the tube is drawn in the cable's colour where the rod's points project: dark pixels, not the robot's orange
    picture = renderer.render(data, close, cables=cables)
    assert np.median(picture[rod].astype(int), axis=0).max() < 90
    # MuJoCo's own cable (on its straight rest line in these positions) is hidden
    assert not _cable_mask(renderer, data, NO_CABLES, close).any()


def test_cables_given_as_points_are_checked(station):
    with pytest.raises(ConfigError, match="cables.points"):
        CablePoints((np.zeros((1, 3)),), (0.03,))
    with pytest.raises(ConfigError, match="cables.radii"):
        CablePoints((np.zeros((4, 3)),), (0.0,))
    with pytest.raises(ConfigError, match="cables.edge_rgba"):
        CablePoints((np.zeros((4, 3)),), (0.03,), (np.ones((4, 4)),))


def test_animate_writes_a_gif_for_the_rod_engine_from_kept_points_and_by_replaying(station, fast, tmp_path,
                                                                                   monkeypatch):
    imageio = pytest.importorskip("imageio.v2")
    import dresspack_gym.io.animation as animation

    traj = _trajectory(station)
    kwargs = {"fps": 5.0, "width": 96, "height": 64, "strip_height": 32}
    again = animation.animate(fast, traj, tmp_path / "again.gif", **kwargs)
    rep = replay(fast, traj, record_every=0.2, record_qpos=True, record_states=False)
    with monkeypatch.context() as patch:
        patch.setattr(animation, "replay", lambda *a, **k: pytest.fail("the video simulated again"))
        kept = animation.animate(fast, traj, tmp_path / "kept.gif", measured=rep, **kwargs)
    a = np.stack([f[..., :3] for f in imageio.mimread(tmp_path / "again.gif")])
    b = np.stack([f[..., :3] for f in imageio.mimread(tmp_path / "kept.gif")])
    assert again["frames"] == kept["frames"] == len(a) == len(b) > 3
    # the same simulation drawn live or from its kept points: the same pictures
    assert np.abs(a.astype(int) - b.astype(int)).max() <= 8
    with pytest.raises(ConfigError, match="measured"):
        animation.animate(make_simulator(station, "dynamic"), traj, tmp_path / "x.gif", measured=rep, **kwargs)


def test_the_worst_moment_of_a_rod_replay_is_pictured_from_its_points_or_by_replaying(station, fast, renderer,
                                                                                     tmp_path):
    from dresspack.eval.report import _worst_frames
    from PIL import Image

    traj = _trajectory(station)
    (tmp_path / "trajectories").mkdir()
    np.savez(tmp_path / "trajectories" / "k.npz", waypoints=traj.waypoints, stops=np.array(traj.stops))
    rows = [{"method": "m", "success": True, "max_cost": 1.0, "key": "k", "task": "t", "seed": 0}]
    rep = replay(fast, traj, record_qpos=True)
    data = mujoco.MjData(station.model)
    cables = replay_frame(station, rep, int(np.argmax(rep.cost)), data)
    masks = {}
    for kept in (True, False):
        shown = rep if kept else replay(fast, traj)  # without positions: simulated again up to the worst moment
        figures = {}
        blocks = _worst_frames(rows, ["m"], {"k": shown}, station, fast, tmp_path, tmp_path, figures, 0)
        assert blocks[0][0] == "img" and figures["worst m"] == str(tmp_path / "worst_m.png")
        picture = np.asarray(Image.open(figures["worst m"]).convert("RGB"), dtype=int)
        big = _renderer_of_size(station, picture.shape)
        bare = big.render(data, cables=NO_CABLES).astype(int)
        if kept:  # drawn from the kept points: the picture of them
            np.testing.assert_array_equal(picture, big.render(data, cables=cables))
        masks[kept] = np.abs(picture - bare).sum(axis=-1) > 30
        big.close()
        assert masks[kept].sum() > 1000
    # simulated again, the worst moment is caught mid-motion before its settle: nearly the same cable
    assert (masks[True] & masks[False]).sum() / (masks[True] | masks[False]).sum() > 0.8


def _renderer_of_size(station, shape):
    """A renderer of the worst-moment pictures' size (with their shadows)."""
    from dresspack_gym.stations.rendering import StationRenderer

    return StationRenderer(station.model, width=shape[1], height=shape[0])


def test_the_viewers_frames_on_the_rod_engine_are_the_replays_points_coloured_by_their_segments_costs(station, fast):
    from dresspack_gym.io import viewer
    from dresspack_gym.physics.wear_cost import wear_cost

    home = viewer.record_frames(fast, None)
    cost = wear_cost(fast.measures(), station.config.wear_cost)
    assert home.engine == "fast" and home.cost.shape == (1, station.cables[0].n_vertices)
    assert home.cost.max() <= cost.total + 1e-9  # no segment costs more than C (each term at its worst segment)
    np.testing.assert_array_equal(home.points[0], fast.cable_points(0))
    traj = _trajectory(station)
    frames = viewer.record_frames(fast, traj, fps=10.0)
    rep = replay(fast, traj, record_every=0.1, record_qpos=True)
    n = len(rep.time)
    assert frames.cost.shape == (n, station.cables[0].n_vertices) and np.ptp(frames.cost.max(axis=1)) > 0
    np.testing.assert_array_equal(frames.points, rep.cables[0])
    np.testing.assert_array_equal(frames.qpos, rep.qpos)
    assert len(frames.cables) == station.n_robots and frames.radii == (station.cables[0].radius,)
    # the scene: this cable's capsules in its costs' colours, another's in the cable's colour after them
    scene = mujoco.MjvScene(station.model, maxgeom=200)
    other = CablePoints((frames.points[0],), (0.01,))
    viewer.draw_cable(scene, frames.points[-1], frames.cost[-1], frames.scale, frames.radius, other)
    edges = len(frames.points[-1]) - 1
    assert scene.ngeom == 2 * edges
    assert scene.geoms[edges].size[0] == pytest.approx(0.01)
    np.testing.assert_allclose(scene.geoms[edges].rgba, CABLE_RGBA, atol=1e-6)


def test_dresspack_animate_replays_on_the_engine_asked(station, tmp_path, capsys):
    pytest.importorskip("imageio.v2")
    from dresspack_gym.cli.main import main
    from dresspack_gym.physics.trajectory import save_trajectory

    plan = tmp_path / "plan.npz"
    save_trajectory(plan, _trajectory(station), station="default", robot="r1", speed_fraction=0.5)
    args = ["animate", str(plan), "--fps", "4", "--width", "64", "--height", "48"]
    assert main(args + ["--out", str(tmp_path / "a.gif"), "--physics", "fast"]) == 0
    assert (tmp_path / "a.gif").stat().st_size > 1000 and "wrote" in capsys.readouterr().out
    with pytest.raises(SystemExit) as refused:
        main(args + ["--out", str(tmp_path / "b.gif"), "--physics", "quick"])
    assert refused.value.code == 2
    assert "--physics" in capsys.readouterr().err and not (tmp_path / "b.gif").exists()


def test_wear_coloured_videos_draw_the_same_frames_live_or_kept_on_either_engine(station, fast, tmp_path, monkeypatch):
    imageio = pytest.importorskip("imageio.v2")
    import dresspack_gym.io.animation as animation

    traj = _trajectory(station)
    close = default_camera(station.model, distance=1.6, lookat=fast.cable_points(0).mean(axis=0))
    kwargs = {"fps": 5.0, "width": 96, "height": 64, "strip_height": 32, "camera": close}

    def frames(name):
        return np.stack([f[..., :3] for f in imageio.mimread(tmp_path / name)]).astype(int)

    animation.animate(fast, traj, tmp_path / "plain.gif", **kwargs)
    animation.animate(fast, traj, tmp_path / "live.gif", wear_colours=True, **kwargs)
    kept = replay(fast, traj, record_every=0.2, record_qpos=True, keep_states=True)
    unkept = replay(fast, traj, record_every=0.2, record_qpos=True)
    simulated = []
    with monkeypatch.context() as patch:
        patch.setattr(animation, "replay", lambda *a, **k: pytest.fail("the video simulated again"))
        animation.animate(fast, traj, tmp_path / "kept.gif", measured=kept, wear_colours=True, **kwargs)
        # the rod's points without its segment states cannot be coloured: simulated again
        patch.setattr(animation, "replay", lambda *a, **k: simulated.append(1) or replay(*a, **k))
        animation.animate(fast, traj, tmp_path / "again.gif", measured=unkept, wear_colours=True, **kwargs)
    plain, live = frames("plain.gif"), frames("live.gif")
    assert np.abs(live - frames("kept.gif")).max() <= 8 and np.abs(live - frames("again.gif")).max() <= 8
    assert simulated == [1]
    # the cable changes colour and nothing else: blue where a segment costs little
    changed = np.abs(live - plain).sum(axis=-1) > 30
    assert changed.sum() > 100
    assert np.median(live[changed][:, 2] - live[changed][:, 0]) > 40
    # MuJoCo's kept positions are posed in its simulator to read its segment states, which are put back after
    dynamic = make_simulator(station, "dynamic")
    mujoco_kept = replay(dynamic, traj, record_every=0.2, record_qpos=True)
    before = dynamic.get_state()
    animation.animate(dynamic, traj, tmp_path / "mujoco.gif", measured=mujoco_kept, wear_colours=True, **kwargs)
    np.testing.assert_array_equal(dynamic.get_state(), before)
    mujoco_frames = frames("mujoco.gif")
    assert len(mujoco_frames) == len(live)
    assert (np.abs(mujoco_frames - plain).sum(axis=-1) > 30).sum() > 100
