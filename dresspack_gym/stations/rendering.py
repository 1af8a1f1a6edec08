"""Offscreen pictures of a station (MuJoCo renderer; set MUJOCO_GL=egl on a headless machine)."""

from __future__ import annotations

import mujoco
import numpy as np

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
        # Shadows are ~90 % of a frame's time in software rendering (0.33 s vs 0.035 s at 320 x 180 on the CPU):
        # videos turn them off, still pictures keep them.
        self.shadows = bool(shadows)

    def render(self, data: mujoco.MjData, camera: mujoco.MjvCamera | None = None) -> np.ndarray:
        cam = camera if camera is not None else default_camera(self.model)
        self.renderer.update_scene(data, camera=cam, scene_option=self.option)
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.shadows
        return self.renderer.render().copy()

    def close(self) -> None:
        self.renderer.close()


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
