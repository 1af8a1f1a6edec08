"""The picture of docs/rod_engine.md: one plan at its costliest moment drawn from MuJoCo's replay and the rod engine's.

The plan is Home -> the default station's first roof_rail_top weld -> Home; each engine replays it keeping its
positions (``record_qpos``), and each is drawn at its own costliest sample with the same camera (looking at the rod
engine's cable there): MuJoCo's cable is its own flex, the rod engine's a tube through its vertices.

    .venv/bin/python scripts/studies/rod_engine_render.py [--out docs/rod_engine_render.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import make_simulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.rendering import StationRenderer, default_camera, replay_frame, save_png
from dresspack_gym.stations.station import Station

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "rod_engine_render.png"))
    args = parser.parse_args()
    station = Station(load_station("default"))
    home = station.home[0]
    weld = np.asarray(station.weld_configurations["roof_rail_top"]).reshape(-1, 6)[0]
    traj = Trajectory(np.stack([home, weld, home]), (1, 2))
    frames = []
    for engine in ("dynamic", "fast"):
        rep = replay(make_simulator(station, engine), traj, record_qpos=True)
        i = int(np.argmax(rep.cost))
        data = mujoco.MjData(station.model)
        frames.append((data, replay_frame(station, rep, i, data)))
        print(f"{engine}: costliest at t = {rep.time[i]:.2f} s, C = {rep.cost[i]:.3g}")
    rod_cable = frames[1][1].points[0]
    cam = default_camera(station.model, distance=2.0, lookat=tuple(rod_cable.mean(axis=0)), azimuth=-70,
                         elevation=-15)
    renderer = StationRenderer(station.model, width=480, height=360)
    save_png(np.hstack([renderer.render(data, cam, cables=cables) for data, cables in frames]), args.out)
    renderer.close()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
