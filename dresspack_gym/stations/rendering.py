"""Offscreen pictures of a station (MuJoCo renderer; set MUJOCO_GL=egl on a headless machine)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..cable.model import CABLE_RGBA
from ..errors import ConfigError, DresspackError

# The offscreen framebuffer every station is compiled with (stations/station.py): the largest frame it can render.
OFFSCREEN_WIDTH, OFFSCREEN_HEIGHT = 1280, 960


def default_camera(model: mujoco.MjModel, azimuth: float = -60.0, elevation: float = -22.0,
                   distance: float | None = None, lookat=(0.4, 0.0, 1.1)) -> mujoco.MjvCamera:
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.azimuth, cam.elevation = azimuth, elevation
    cam.distance = distance if distance is not None else 5.5
    cam.lookat[:] = lookat
    return cam


@dataclass(frozen=True)
class CablePoints:
    """Cables to draw from their centrelines: per cable its vertices (V, 3) [m] and radius [m], and optionally an
    RGBA per edge (V - 1, 4); without one a cable has MuJoCo's cable colour (cable.model.CABLE_RGBA)."""

    points: tuple[np.ndarray, ...]
    radii: tuple[float, ...]
    edge_rgba: tuple[np.ndarray | None, ...] | None = None

    def __post_init__(self):
        points = tuple(np.asarray(p, dtype=float) for p in self.points)
        for i, p in enumerate(points):
            if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2 or not np.isfinite(p).all():
                raise ConfigError(f"cables.points[{i}]", f"expected (V >= 2, 3) finite vertex positions, "
                                                         f"got shape {p.shape}")
        if len(self.radii) != len(points) or not all(float(r) > 0 for r in self.radii):
            raise ConfigError("cables.radii", f"expected one positive radius per cable ({len(points)}), "
                                              f"got {list(self.radii)}")
        if self.edge_rgba is not None:
            if len(self.edge_rgba) != len(points):
                raise ConfigError("cables.edge_rgba", f"expected one entry per cable ({len(points)}), "
                                                      f"got {len(self.edge_rgba)}")
            for i, (c, p) in enumerate(zip(self.edge_rgba, points)):
                if c is not None and np.shape(c) != (len(p) - 1, 4):
                    raise ConfigError(f"cables.edge_rgba[{i}]", f"expected ({len(p) - 1}, 4) RGBA per edge, "
                                                                f"got shape {np.shape(c)}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "radii", tuple(float(r) for r in self.radii))

    def draw(self, scene: mujoco.MjvScene) -> None:
        """Add one capsule per cable edge to ``scene`` after its geoms (as many as it has room for: a scene
        short of room shows the cable's start, never fails a picture)."""
        default = np.array(CABLE_RGBA, dtype=np.float32)
        for i, (points, radius) in enumerate(zip(self.points, self.radii)):
            colours = None if self.edge_rgba is None else self.edge_rgba[i]
            for e in range(len(points) - 1):
                if scene.ngeom >= scene.maxgeom:
                    return
                rgba = default if colours is None else np.asarray(colours[e], dtype=np.float32)
                geom = scene.geoms[scene.ngeom]
                mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3),
                                    np.eye(3).ravel(), rgba)
                mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, radius, points[e], points[e + 1])
                scene.ngeom += 1


class StationRenderer:
    """Renders RGB frames of a model/data pair; reuse one instance for many frames."""

    def __init__(self, model: mujoco.MjModel, width: int = 960, height: int = 720, *, shadows: bool = True):
        check_frame_size(width, height, model)
        try:
            self.renderer = mujoco.Renderer(model, height=height, width=width)
        except Exception as exc:  # no GL context available
            raise DresspackError(f"offscreen rendering is unavailable ({exc}); on a headless machine "
                                 f"install EGL (libegl1) and set MUJOCO_GL=egl") from None
        self.model = model
        self.option = mujoco.MjvOption()
        self.option.geomgroup[5] = 0  # hide the clearance probe
        # Cables drawn from their points replace MuJoCo's: its skin (a station's flexes are its cables) and the
        # cable bodies' geoms (group 3, hidden anyway) must not show where MuJoCo left them.
        self.points_option = mujoco.MjvOption()
        self.points_option.geomgroup[:] = self.option.geomgroup
        self.points_option.geomgroup[3] = 0
        for group in set(int(g) for g in model.flex_group) | set(int(g) for g in model.skin_group):
            if 0 <= group < len(self.points_option.flexgroup):
                self.points_option.flexgroup[group] = 0
                self.points_option.skingroup[group] = 0
        # Shadows are ~90 % of a frame's time in software rendering (0.33 s vs 0.035 s at 320 x 180 on the CPU):
        # videos turn them off, still pictures keep them.
        self.shadows = bool(shadows)

    def render(self, data: mujoco.MjData, camera: mujoco.MjvCamera | None = None, *,
               cables: CablePoints | None = None) -> np.ndarray:
        """The RGB frame of ``data`` seen from ``camera``; with ``cables`` (the rod engine's) those are drawn in
        place of MuJoCo's own."""
        cam = camera if camera is not None else default_camera(self.model)
        self.renderer.update_scene(data, camera=cam,
                                   scene_option=self.option if cables is None else self.points_option)
        if cables is not None:
            cables.draw(self.renderer.scene)
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.shadows
        return self.renderer.render().copy()

    def close(self) -> None:
        self.renderer.close()


def station_cables(station, points) -> CablePoints:
    """``points``, one centreline per robot of ``station`` (a Station), as cables of their dresspacks' radii."""
    points = tuple(points)
    if len(points) != station.n_robots:
        raise ConfigError("cables", f"expected one cable per robot ({station.n_robots}), got {len(points)}")
    return CablePoints(points, tuple(c.radius for c in station.cables))


def live_frame(sim, data: mujoco.MjData | None = None) -> tuple[mujoco.MjData, CablePoints | None]:
    """What draws a cable simulator of either engine as it stands: MuJoCo's data and, when the cables are not
    MuJoCo's (the rod engine), their points. MuJoCo's simulator draws its own ``sim.data``; the rod engine's
    robots are posed on ``data`` (a fresh one if None)."""
    if sim.engine == "dynamic":
        return sim.data, None
    model = sim.station.model
    data = mujoco.MjData(model) if data is None else data
    data.qpos[:] = sim.mujoco_qpos()
    mujoco.mj_forward(model, data)
    return data, station_cables(sim.station, [sim.cable_points(r) for r in range(sim.station.n_robots)])


def replay_frame(station, rep, index: int, data: mujoco.MjData) -> CablePoints | None:
    """Pose ``data`` as sample ``index`` of ``rep`` (a Replay that kept its positions, ``record_qpos``); the
    cables to draw from their points (a rod-engine replay's), or None when MuJoCo's own show them."""
    if rep.qpos is None:
        raise ConfigError("replay", "kept no positions to draw: replay it with record_qpos=True")
    data.qpos[:] = rep.qpos[index]
    data.qvel[:] = 0.0
    mujoco.mj_forward(station.model, data)
    return None if rep.cables is None else station_cables(station, [c[index] for c in rep.cables])


def check_frame_size(width, height, model: mujoco.MjModel | None = None, field: str = "render_size") -> None:
    """A frame size the offscreen buffer can hold: positive integers up to its size."""
    w_max = int(model.vis.global_.offwidth) if model is not None else OFFSCREEN_WIDTH
    h_max = int(model.vis.global_.offheight) if model is not None else OFFSCREEN_HEIGHT
    for name, v, hi in (("width", width, w_max), ("height", height, h_max)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= hi:
            raise ConfigError(f"{field}.{name}", f"{v!r} is not allowed: must be an integer in [1, {hi}] px")


def save_png(image: np.ndarray, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.imsave(path, image)
