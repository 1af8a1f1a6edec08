"""MuJoCo's interactive viewer replaying a plan (or a station at Home), the cable coloured by its wear cost."""

from __future__ import annotations

import os
import sys
import time
import warnings
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import DresspackError
from ..physics.measures import ClearanceProbe
from ..physics.segment_cost import segment_clearances, segment_wear_cost
from ..physics.simulation import CableSimulator
from ..physics.trajectory import Trajectory, replay
from ..stations.rendering import CablePoints

# GLFW key codes (the viewer's key callback receives them; keys it does not use itself)
KEY_SPACE, KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP = 32, 262, 263, 264, 265
KEY_PAGE_UP, KEY_PAGE_DOWN, KEY_HOME, KEY_END = 266, 267, 268, 269
KEYS_HELP = "space play/pause, left/right one frame, PgUp/PgDn 1 s, Home/End, up/down speed"  # MuJoCo's font: ASCII
# the cable's colour from no cost to the largest of the replay: blue, yellow, red
RAMP = np.array([[0.15, 0.35, 0.85], [0.95, 0.80, 0.15], [0.85, 0.10, 0.10]])
SPEEDS = (0.125, 8.0)  # the playback speeds ↑/↓ reach, x motion time


class NoDisplay(DresspackError):
    """The viewer needs a display: the command says which one writes a file instead."""


@dataclass(frozen=True)
class CableFrames:
    """A replay's samples ready to show: MuJoCo positions, one cable's vertices and each segment's wear cost."""

    time: np.ndarray  # (N,) motion time [s]; a settle at a stop adds a sample at the same time
    qpos: np.ndarray  # (N, nq)
    points: np.ndarray  # (N, n + 1, 3) the cable's vertices
    cost: np.ndarray  # (N, n + 1) eq. (4.10) per segment (physics.segment_cost)
    radius: float  # the cable's radius [m]
    engine: str = "dynamic"  # the cable engine replayed (physics.profiles.ENGINES)
    # on the rod engine, whose cables MuJoCo's positions do not hold: every robot's cable, (N, vertices, 3) each,
    # and its radius, to draw the other robots' cables from their points too
    cables: tuple[np.ndarray, ...] = ()
    radii: tuple[float, ...] = ()

    @property
    def scale(self) -> float:
        """The cost the colour ramp ends at: the largest of any segment over the replay (1 if it is all 0)."""
        top = float(self.cost.max()) if self.cost.size else 0.0
        return top if top > 0.0 else 1.0


def record_frames(sim: CableSimulator, traj: Trajectory | None, *, robot: int = 0, fps: float = 20.0,
                  speed_fraction: float | None = None, progress=None) -> CableFrames:
    """The frames of ``traj`` replayed at ``fps`` samples per second of motion time (with the settled shape at
    each stop), or with no trajectory the station settled at Home, one frame; on either engine (``sim``'s).
    On MuJoCo each frame's segment costs are read from the static forces of its shape, as the replay's measures
    are; on the rod engine from the segment states the replay measured. ``progress(done, total)`` after each."""
    if sim.engine != "dynamic":
        return _rod_frames(sim, traj, robot=robot, fps=fps, speed_fraction=speed_fraction, progress=progress)
    if traj is None:
        sim.reset()
        positions = [sim.data.qpos.copy()]
        times = np.zeros(1)
    else:
        rep = replay(sim, traj, robot=robot, record_every=1.0 / fps, speed_fraction=speed_fraction,
                     record_states=False, record_qpos=True)
        positions, times = list(rep.qpos), rep.time
    station = sim.station
    cable = station.cables[robot]
    cfg, ea = station.config.wear_cost, station.config.robots[robot].dresspack.tensile_stiffness
    points, costs = [], []
    for i, qpos in enumerate(positions):
        sim.data.qpos[:] = qpos
        sim.data.qvel[:] = 0.0
        mujoco.mj_forward(sim.model, sim.data)
        shape = sim.cable_points(robot)
        state = sim.segment_states()[robot]
        points.append(shape)
        costs.append(segment_wear_cost(state, segment_clearances(sim.probe, sim.data, cable, shape), cfg, ea))
        if progress is not None:
            progress(i + 1, len(positions))
    return CableFrames(np.asarray(times, dtype=float), np.array(positions), np.array(points), np.array(costs),
                       float(cable.radius))


def _rod_frames(sim, traj: Trajectory | None, *, robot: int, fps: float, speed_fraction: float | None,
                progress) -> CableFrames:
    """:func:`record_frames` on the rod engine: the robots in MuJoCo's positions, every cable's points, and the
    segment costs of the states the replay measured (the rod's state is not MuJoCo's to re-pose)."""
    station = sim.station
    if traj is None:
        sim.reset()
        times, positions = np.zeros(1), np.array([sim.mujoco_qpos()])
        cables = tuple(sim.cable_points(r)[None] for r in range(station.n_robots))
        states = [sim.segment_states()[robot]]
    else:
        rep = replay(sim, traj, robot=robot, record_every=1.0 / fps, speed_fraction=speed_fraction,
                     record_qpos=True, keep_states=True)
        times, positions, cables, states = rep.time, rep.qpos, rep.cables, rep.states
    cable = station.cables[robot]
    cfg, ea = station.config.wear_cost, station.config.robots[robot].dresspack.tensile_stiffness
    probe, data = ClearanceProbe(station), mujoco.MjData(station.model)
    costs = []
    for i, (qpos, state) in enumerate(zip(positions, states)):
        data.qpos[:] = qpos
        mujoco.mj_kinematics(station.model, data)
        shape = cables[robot][i]
        costs.append(segment_wear_cost(state, segment_clearances(probe, data, cable, shape), cfg, ea))
        if progress is not None:
            progress(i + 1, len(positions))
    return CableFrames(np.asarray(times, dtype=float), np.asarray(positions), np.asarray(cables[robot]),
                       np.array(costs), float(cable.radius), sim.engine, tuple(np.asarray(c) for c in cables),
                       tuple(float(c.radius) for c in station.cables))


def colours(cost: np.ndarray, scale: float) -> np.ndarray:
    """RGBA of each cost on the ramp from 0 (blue) through scale / 2 (yellow) to ``scale`` and above (red)."""
    u = np.clip(np.asarray(cost, dtype=float) / scale, 0.0, 1.0) * (len(RAMP) - 1)
    lo = np.minimum(u.astype(int), len(RAMP) - 2)
    rgb = RAMP[lo] + (u - lo)[..., None] * (RAMP[lo + 1] - RAMP[lo])
    return np.concatenate([rgb, np.ones(rgb.shape[:-1] + (1,))], axis=-1)


def draw_cable(scene: mujoco.MjvScene, points: np.ndarray, cost: np.ndarray, scale: float, radius: float,
               others: CablePoints | None = None) -> None:
    """Replace ``scene``'s geoms by one capsule per cable edge, coloured by the costlier of its two segments (and
    ``others``, the other robots' cables, in the cable's colour)."""
    rgba = colours(np.maximum(cost[:-1], cost[1:]), scale).astype(np.float32)
    scene.ngeom = 0
    CablePoints((points,), (radius,), (rgba,)).draw(scene)
    if others is not None:
        others.draw(scene)


class Playback:
    """Which frame shows: a clock in motion time that runs while playing, stepped and scrubbed by keys."""

    def __init__(self, time: np.ndarray, speed: float = 1.0, at: float | None = None):
        """Playing from the start, or paused at motion time ``at``."""
        self.time = np.asarray(time, dtype=float)
        self.clock = float(self.time[0])
        self.index = 0
        self.playing = len(self.time) > 1 and at is None
        self.speed = float(speed)
        if at is not None:
            self._seek(at)

    def key(self, keycode: int) -> None:
        """The viewer's key callback (see KEYS_HELP)."""
        if keycode == KEY_SPACE:
            self.playing = not self.playing
            if self.playing and self.index == len(self.time) - 1:  # at the end: play from the start
                self._show(0)
        elif keycode in (KEY_RIGHT, KEY_LEFT):
            self.playing = False
            self._show(self.index + (1 if keycode == KEY_RIGHT else -1))
        elif keycode in (KEY_PAGE_UP, KEY_PAGE_DOWN):
            self._seek(self.clock + (1.0 if keycode == KEY_PAGE_DOWN else -1.0))
        elif keycode in (KEY_HOME, KEY_END):
            self._show(0 if keycode == KEY_HOME else len(self.time) - 1)
        elif keycode in (KEY_UP, KEY_DOWN):
            self.speed = float(np.clip(self.speed * (2.0 if keycode == KEY_UP else 0.5), *SPEEDS))

    def advance(self, wall_seconds: float) -> int:
        """Run the clock by ``wall_seconds`` x speed while playing (pausing at the end); the frame to show."""
        if self.playing:
            self._seek(self.clock + wall_seconds * self.speed)
            if self.index == len(self.time) - 1:
                self.playing = False
        return self.index

    def _seek(self, clock: float) -> None:
        """The last frame at or before ``clock`` (so a stop shows its settled shape)."""
        self.clock = float(np.clip(clock, self.time[0], self.time[-1]))
        self.index = int(np.searchsorted(self.time, self.clock, side="right")) - 1

    def _show(self, index: int) -> None:
        self.index = int(np.clip(index, 0, len(self.time) - 1))
        self.clock = float(self.time[self.index])


def display_problem() -> str | None:
    """Why MuJoCo's viewer cannot open a window here, or None."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display to open MuJoCo's viewer on (DISPLAY is not set)"
    try:
        import glfw
    except ImportError:
        return "MuJoCo's viewer needs glfw (pip install glfw)"
    with warnings.catch_warnings():  # glfw reports a failed init as a warning too: the message below says it
        warnings.simplefilter("ignore")
        if not glfw.init():
            return f"no display to open MuJoCo's viewer on (GLFW cannot open {os.environ.get('DISPLAY', '')!r})"
    return None


def require_display(instead: str) -> None:
    """:class:`NoDisplay` (why, then ``instead``: the command that writes a file to look at) unless the viewer can
    open a window here."""
    problem = display_problem()
    if problem is not None:
        raise NoDisplay(f"{problem}; {instead}")


def view(sim: CableSimulator, frames: CableFrames, *, robot: int = 0, instead: str, title: str = "",
         at: float | None = None, max_seconds: float | None = None) -> None:
    """Open MuJoCo's viewer on ``frames`` and play them (or stand paused at motion time ``at``) until the window
    closes (or ``max_seconds`` pass).
    Without a display, :class:`NoDisplay` with ``instead``, the command that writes a file to look at."""
    require_display(instead)
    import mujoco.viewer

    model = sim.station.model
    data = mujoco.MjData(model)
    # the coloured capsules draw this cable; on the rod engine capsules draw the other robots' cables too
    drawn = [robot] if not frames.cables else range(sim.station.n_robots)
    for piece in (p for r in drawn for p in sim.station.cables[r].pieces):
        model.flex_rgba[piece.flex_id, 3] = 0.0
    others = [r for r in range(len(frames.cables)) if r != robot]
    playback = Playback(frames.time, at=at)
    scale = frames.scale
    # no side panels (Tab and Shift+Tab show them): the window is the station
    with mujoco.viewer.launch_passive(model, data, key_callback=playback.key, show_left_ui=False,
                                      show_right_ui=False) as handle:
        start = last = time.perf_counter()
        while handle.is_running() and (max_seconds is None or time.perf_counter() - start < max_seconds):
            now = time.perf_counter()
            i = playback.advance(now - last)
            last = now
            with handle.lock():
                data.qpos[:] = frames.qpos[i]
                mujoco.mj_forward(model, data)
                draw_cable(handle.user_scn, frames.points[i], frames.cost[i], scale, frames.radius,
                           CablePoints([frames.cables[r][i] for r in others], [frames.radii[r] for r in others]))
            state = "playing" if playback.playing else "paused"
            handle.set_texts([  # takes the viewer's lock itself
                (None, mujoco.mjtGridPos.mjGRID_TOPLEFT, f"{title}\n{KEYS_HELP}", ""),
                (None, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT,
                 f"t = {frames.time[i]:.2f} / {frames.time[-1]:.2f} s  ({state}, x{playback.speed:g})\n"
                 f"costliest segment: C = {frames.cost[i].max():.3g}  (red: {scale:.3g}, the replay's costliest)",
                 ""),
            ])
            handle.sync()
            if _unmoved(handle.cam):  # MuJoCo's default camera, which the viewer's render thread sets on load
                _look_at_station(handle, model)
            time.sleep(1.0 / 60.0)


def _unmoved(cam: mujoco.MjvCamera) -> bool:
    """Whether ``cam`` is MuJoCo's default camera (nobody has moved it)."""
    default = mujoco.MjvCamera()
    return (cam.type == default.type and cam.distance == default.distance and cam.azimuth == default.azimuth
            and cam.elevation == default.elevation and np.array_equal(cam.lookat, default.lookat))


def _look_at_station(handle, model: mujoco.MjModel) -> None:
    from ..stations.rendering import default_camera

    cam = default_camera(model)
    with handle.lock():
        handle.opt.geomgroup[5] = 0  # the clearance probe
        handle.cam.type, handle.cam.distance = cam.type, cam.distance
        handle.cam.azimuth, handle.cam.elevation = cam.azimuth, cam.elevation
        handle.cam.lookat[:] = cam.lookat
