"""Videos of a replayed trajectory: offscreen MuJoCo frames of the robot and its cable, with the wear measures
drawn as a strip under them and a cursor at the frame's time (MP4 through imageio-ffmpeg, or GIF)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from ..errors import ConfigError
from ..physics.measures import ClearanceProbe
from ..physics.segment_cost import segment_clearances, segment_wear_cost
from ..physics.simulation import CableSimulator
from ..physics.trajectory import Replay, Trajectory, replay
from ..stations.rendering import CablePoints, StationRenderer, default_camera, live_frame, replay_frame
from .viewer import colours

VIDEO_FORMATS = (".mp4", ".gif")


def _strip(rep: Replay, width: int, height: int) -> tuple[np.ndarray, callable]:
    """The measures-over-time strip as an RGB image, and t -> pixel column of the time axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dpi = 100
    fig, ax = plt.subplots(figsize=(width / dpi, height / dpi), dpi=dpi)
    t = rep.time
    kappa0 = rep.thresholds.get("curvature")
    ax.plot(t, rep.measures["curvature"], color="#d1495b", lw=1.2, label="κ [1/m]")
    if kappa0 is not None:
        ax.axhline(kappa0, color="#d1495b", lw=0.6, ls="--")
    ax.plot(t, rep.measures["tension"] / 10.0, color="#2e4057", lw=1.2, label="F / 10 [N]")
    ax.plot(t, 10.0 * rep.measures["clearance"], color="#00798c", lw=1.2, label="10 d [m]")
    for s in rep.stop_times:
        ax.axvline(s, color="grey", lw=0.5, ls=":")
    ax.set_xlim(t[0], t[-1] if t[-1] > t[0] else t[0] + 1.0)
    ax.tick_params(labelsize=6)
    ax.set_xlabel("motion time [s]", fontsize=6, labelpad=1)
    ax.legend(fontsize=6, loc="upper right", ncol=3, frameon=False)
    fig.subplots_adjust(left=0.06, right=0.99, top=0.97, bottom=0.24)
    fig.canvas.draw()
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    x0, x1 = ax.get_xlim()
    p0 = ax.transData.transform((x0, 0))[0]
    p1 = ax.transData.transform((x1, 0))[0]
    plt.close(fig)
    return image, lambda time: int(round(p0 + (time - x0) / (x1 - x0) * (p1 - p0)))


def animate(sim: CableSimulator, traj: Trajectory, out: str | Path, *, robot: int = 0, fps: float = 20.0,
            width: int = 640, height: int = 360, strip_height: int = 120, camera=None,
            measured: Replay | None = None, progress=None, shadows: bool = False, wear_colours: bool = False) -> dict:
    """Write the video of ``traj`` replayed from its start on ``sim`` (either engine: a rod-engine simulator's
    cables are drawn from their points); returns {"path", "frames", "duration_s"}.

    Frames are the replay's samples every 1/fps s of motion time (the settles at the welds take no motion time,
    so they show as one frame), rendered during a second, identical replay (the simulation is deterministic);
    ``measured``, a replay of the same trajectory already made, saves the first, and both if it kept its positions
    (``record_qpos``) on a sample grid at least as fine as 1/fps. ``progress(label, total)``, a
    tqdm-like bar factory, shows the replay's samples, then the frames written. ``shadows`` costs ~10x per frame
    in software rendering, so videos are drawn without them unless asked. With ``wear_colours`` the robot's cable
    is drawn segment by segment in the colour of its wear cost as ``dresspack view`` draws it (blue none, red the
    replay's largest C, which no segment exceeds); a rod-engine replay kept for it must also have kept its segment
    states (``keep_states``), else it is simulated again."""
    out = Path(out)
    if out.suffix not in VIDEO_FORMATS:
        raise ConfigError("out", f"{out.name}: the video format is chosen by the suffix, one of {list(VIDEO_FORMATS)}")
    if not 1 <= fps <= 60:
        raise ConfigError("fps", f"must be in [1, 60], got {fps}")
    import imageio.v2 as imageio

    if measured is not None and measured.engine != sim.engine:
        raise ConfigError("measured", f"a replay on the {measured.engine!r} engine cannot stand for a video on the "
                                      f"{sim.engine!r} engine: measure it with the simulator that draws it")
    bar = progress or _NoBar
    samples = 0  # the frames the rendering replay will write (it samples as this one does)
    rep = measured
    drawn = frame_samples(rep, fps) if rep is not None else None
    if wear_colours and drawn is not None and rep.cables is not None and rep.states is None:
        drawn = None  # the rod's segment states are not in its points: simulate again to read them
    if drawn is not None:
        samples = len(drawn)
    if rep is None:
        with bar("replaying", None) as replayed:
            def sampled(t: float) -> None:
                nonlocal samples
                samples += 1
                replayed.update(1)

            rep = replay(sim, traj, robot=robot, record_every=1.0 / fps, record_states=False, on_sample=sampled)
    strip, column = _strip(rep, width, strip_height)
    renderer = StationRenderer(sim.station.model, width=width, height=height, shadows=shadows)
    cam = camera if camera is not None else default_camera(sim.station.model)
    kwargs = {"fps": fps, "macro_block_size": 2, "codec": "libx264", "quality": 6} if out.suffix == ".mp4" else \
        {"duration": 1.0 / fps, "loop": 0}
    frames = 0
    with imageio.get_writer(out, **kwargs) as writer, bar("rendering", samples or None) as written:
        def frame(t: float, data: mujoco.MjData, cables: CablePoints | None) -> None:
            nonlocal frames
            below = strip.copy()
            x = min(max(column(t), 0), width - 1)
            below[:, max(0, x - 1):x + 1] = (230, 60, 60)  # the time cursor
            writer.append_data(np.vstack([renderer.render(data, cam, cables=cables), below]))
            frames += 1
            written.update(1)

        data = mujoco.MjData(sim.station.model)
        painter = _WearColours(sim, robot, float(rep.cost.max())) if wear_colours else None
        if drawn is not None:  # the replay kept its positions: draw them, no second simulation
            for i in drawn:
                cables = replay_frame(sim.station, rep, i, data)
                frame(float(rep.time[i]), data, cables if painter is None else painter.kept(rep, i, data))
        else:
            def live(t: float) -> None:
                shown, cables = live_frame(sim, data)
                frame(t, shown, cables if painter is None else painter.live(shown))

            replay(sim, traj, robot=robot, record_every=1.0 / fps, record_states=False, on_sample=live)
        if painter is not None:
            painter.restore()
    renderer.close()
    return {"path": str(out), "frames": frames, "duration_s": frames / fps}


class _WearColours:
    """Every cable of a frame as points, the robot's coloured by each segment's wear cost (physics.segment_cost)
    on the ramp of ``dresspack view`` up to ``scale``."""

    def __init__(self, sim, robot: int, scale: float):
        self.sim, self.robot = sim, robot
        self.scale = scale if scale > 0.0 else 1.0
        station = sim.station
        self.cable = station.cables[robot]
        self.radii = tuple(c.radius for c in station.cables)
        self.probe = ClearanceProbe(station)
        self.cfg, self.ea = station.config.wear_cost, station.config.robots[robot].dresspack.tensile_stiffness
        # MuJoCo's segment states are read off its own data: kept positions are posed there, and put back after
        self.saved = sim.get_state() if sim.engine == "dynamic" else None

    def live(self, data: mujoco.MjData) -> CablePoints:
        """The simulator as it stands (``data`` showing it)."""
        points = [self.sim.cable_points(r) for r in range(self.sim.station.n_robots)]
        return self._coloured(data, points, self.sim.segment_states()[self.robot])

    def kept(self, rep: Replay, i: int, data: mujoco.MjData) -> CablePoints:
        """Sample ``i`` of a replay that kept its positions (``data`` posed as it)."""
        if rep.cables is not None:
            return self._coloured(data, [c[i] for c in rep.cables], rep.states[i])
        sim = self.sim
        sim.data.qpos[:] = rep.qpos[i]
        sim.data.qvel[:] = 0.0
        mujoco.mj_forward(sim.model, sim.data)
        return self.live(sim.data)

    def restore(self) -> None:
        if self.saved is not None:
            self.sim.set_state(self.saved)

    def _coloured(self, data: mujoco.MjData, points: list[np.ndarray], state) -> CablePoints:
        shape = points[self.robot]
        cost = segment_wear_cost(state, segment_clearances(self.probe, data, self.cable, shape), self.cfg, self.ea)
        edges = [None] * len(points)
        edges[self.robot] = colours(np.maximum(cost[:-1], cost[1:]), self.scale)
        return CablePoints(tuple(points), self.radii, tuple(edges))


def frame_samples(rep: Replay, fps: float) -> list[int] | None:
    """The samples of a replay to show at ``fps``: one every 1/fps s of motion time, on the replay's own sample
    grid (a sample counts as on time within half the grid's spacing), the first always; None if the replay kept
    no positions or its grid is coarser than 1/fps."""
    time = rep.time
    steps = np.diff(time)
    grid = float(np.median(steps[steps > 0])) if np.any(steps > 0) else 0.0
    if rep.qpos is None or grid > 1.0 / fps + 1e-9:
        return None
    chosen, last = [0], float(time[0])
    for i in range(1, len(time)):
        if time[i] >= last + 1.0 / fps - 0.5 * grid:
            chosen.append(i)
            last = float(time[i])
    return chosen


class _NoBar:
    """A progress bar that shows nothing."""

    def __init__(self, label: str, total: int | None):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass

    def update(self, n: int = 1) -> None:
        pass
