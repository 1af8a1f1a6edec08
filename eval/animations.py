"""The report's videos, one per task and method, rendered on a pool of processes (each video stands alone)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import check_choice
from dresspack_gym.io.animation import animate
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import ENGINES, make_simulator
from dresspack_gym.physics.trajectory import Replay, Trajectory
from dresspack_gym.process_pool import spawn_pool
from dresspack_gym.stations.station import Station

# small: every clip is embedded in report.html
ANIMATION = {"fps": 10.0, "width": 320, "height": 180, "strip_height": 70}


@dataclass(frozen=True)
class Clip:
    """One video to write: a trajectory, where to, and its replay already measured (saves re-simulating it)."""

    path: str
    waypoints: np.ndarray
    stops: tuple[int, ...]
    measured: Replay | None = None


def render_clips(station: str, robot: int, clips: list[Clip], *, jobs: int = 1, progress: bool = False,
                 engine: str = "dynamic") -> None:
    """Write every clip, on ``jobs`` processes, simulated on ``engine`` (one of physics.profiles.ENGINES: a clip's
    measured replay must be of it); a video does not depend on ``jobs`` or on the clips before it (every replay
    starts from a fresh reset)."""
    check_choice("engine", engine, ENGINES)
    for clip in clips:
        if clip.measured is not None and clip.measured.engine != engine:
            raise ConfigError("clips", f"{clip.path}: its replay ran on the {clip.measured.engine!r} engine, the "
                                       f"videos on {engine!r}")
    bar = tqdm(total=len(clips), desc="rendering videos", unit="video", disable=not progress or not clips,
               dynamic_ncols=True)
    try:
        if jobs == 1 or len(clips) < 2:
            sim = make_simulator(Station(load_station(station)), engine)
            for clip in clips:
                _render(sim, robot, clip)
                bar.update(1)
            return
        with spawn_pool(min(jobs, len(clips)), _init_worker, (station, robot, engine)) as pool:
            for _ in pool.imap_unordered(_render_in_worker, clips):
                bar.update(1)
    finally:
        bar.close()


def _render(sim, robot: int, clip: Clip) -> None:
    animate(sim, Trajectory(clip.waypoints, clip.stops), clip.path, robot=robot, measured=clip.measured, **ANIMATION)


_worker: dict = {}


def _init_worker(station: str, robot: int, engine: str) -> None:
    _worker["sim"] = make_simulator(Station(load_station(station)), engine)
    _worker["robot"] = robot


def _render_in_worker(clip: Clip) -> str:
    _render(_worker["sim"], _worker["robot"], clip)
    return clip.path
