"""Weld lists in (CSV), programs out (CSV, JSON, ABB RAPID, KUKA KRL): every row error named, and the round trip
CSV weld list -> plan -> program -> parsed joints equal within 1e-6 rad."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import default_station_dict

from dresspack_gym import ConfigError
from dresspack_gym.io.loading import station_from_dict
from dresspack_gym.io.programs import FORMATS, TimedPath, parse, write
from dresspack_gym.physics.trajectory import Trajectory, load_trajectory_file, save_trajectory
from dresspack_gym.stations.station import Station

HEADER = "name,x,y,z,approach_x,approach_y,approach_z,spin_min_deg,spin_max_deg\n"


def _csv_station(tmp_path, rows: str, units: str = "mm", header: str = HEADER):
    (tmp_path / "welds.csv").write_text(header + rows)
    d = default_station_dict()
    d["weld_points"] = []
    d["weld_points_csv"] = {"path": str(tmp_path / "welds.csv"), "units": units}
    return station_from_dict(d)


def test_csv_weld_list_equals_the_same_welds_written_in_yaml(tmp_path):
    yaml_cfg = station_from_dict(default_station_dict())
    rows = "".join(f"{w.name},{w.pos[0] * 1000:.3f},{w.pos[1] * 1000:.3f},{w.pos[2] * 1000:.3f},"
                   f"{float(w.approach[0])!r},{float(w.approach[1])!r},{float(w.approach[2])!r},0,330\n"
                   for w in yaml_cfg.weld_points)
    csv_cfg = _csv_station(tmp_path, rows)
    assert [w.name for w in csv_cfg.weld_points] == [w.name for w in yaml_cfg.weld_points]
    for a, b in zip(csv_cfg.weld_points, yaml_cfg.weld_points):
        np.testing.assert_allclose(a.pos, b.pos, atol=1e-9)
        np.testing.assert_allclose(a.approach, b.approach, atol=1e-12)
        np.testing.assert_allclose(a.spin, b.spin, atol=1e-12)  # 0..330 step 30 = the default spins


@pytest.mark.parametrize("rows,header,field,match", [
    ("a,1150,-600,abc,0.3,0,-1,,\n", HEADER, "weld_points_csv[welds.csv:row 2].z", "'abc' is not a number"),
    ("a,1150,-600,675,0,0,0,,\n", HEADER, "weld_points_csv[welds.csv:row 2].approach", "non-zero"),
    ("a,1150,-600,675,0.3,0,-1,90,0\n", HEADER, "weld_points_csv[welds.csv:row 2].spin_max_deg", "spin range"),
    ("a,1150,-600,675,0.3,0,-1\n", "name,x,y,z,approach_x,approach_y\n", "weld_points_csv", "missing columns"),
    ("a,1150,-600,675,0.3,0,-1,1\n", "name,x,y,z,approach_x,approach_y,approach_z,colour\n", "weld_points_csv",
     "unknown columns"),
    ("a,1150,-600,675,0.3,0,-1,,\na,1150,600,675,0.3,0,-1,,\n", HEADER, "weld_points[1].name", "used twice"),
    ("a,1150,-600,675,0.3,0,-1,,\nb,1150,-600,9e9,0.3,0,-1,,\n", HEADER, "weld_points_csv[welds.csv:row 3].pos[2]",
     "outside the allowed range"),
])
def test_csv_row_errors_name_row_and_column(tmp_path, rows, header, field, match):
    with pytest.raises(ConfigError) as err:
        _csv_station(tmp_path, rows, header=header)
    assert err.value.field == field and match in str(err.value)


def test_csv_file_and_units_are_checked(tmp_path):
    d = default_station_dict()
    d["weld_points_csv"] = str(tmp_path / "none.csv")
    with pytest.raises(ConfigError, match="file not found"):
        station_from_dict(d)
    with pytest.raises(ConfigError) as err:
        _csv_station(tmp_path, "a,1,1,1,0,0,-1,,\n", units="inch")
    assert err.value.field == "weld_points_csv.units"


def test_csv_weld_list_to_plan_to_programs_round_trip(tmp_path):
    """A weld list from CSV (mm) is planned, saved, written in every format and parsed back: joints within 1e-6
    rad, segment times within 1e-6 s, the program's duration = the replayed cycle time."""
    pytest.importorskip("ompl")
    from dresspack.agents.planners.registry import plan_station

    rows = "stud_a,1085,0,1100,1,0,0,,\nstud_b,1150,-600,675,0.3,0,-1,,\n"
    station = Station(_csv_station(tmp_path, rows))
    run = plan_station(station, "ompl", iterations=500, welds=["stud_a", "stud_b"])
    save_trajectory(tmp_path / "plan.npz", run.plan.trajectory, station="csv", robot="r1", speed_fraction=0.5)
    traj, meta = load_trajectory_file(tmp_path / "plan.npz")
    assert meta == {"station": "csv", "robot": "r1", "speed_fraction": 0.5}
    np.testing.assert_array_equal(traj.waypoints, run.plan.trajectory.waypoints)
    placement = station.config.robots[0]
    path = TimedPath.of(traj, placement.robot, station.config.simulation.speed_fraction, "csv", "r1")
    assert path.times[-1] == pytest.approx(run.replay.cycle_time, abs=station.config.simulation.timestep * len(
        traj.waypoints))  # the simulator rounds each segment up to whole steps
    for fmt in FORMATS:
        joints, times = parse(write(path, fmt), fmt)
        np.testing.assert_allclose(placement.robot.from_controller(joints), traj.waypoints, atol=1e-6, rtol=0)
        if times is not None:
            np.testing.assert_allclose(times, path.times, atol=1e-6, rtol=0)


def test_export_command_writes_every_format(tmp_path, capsys):
    from dresspack_gym.cli.main import main

    traj = Trajectory(np.radians([[0, -20, 10, 180, -60, 180], [10, -10, 20, 170, -50, 190],
                                  [0, -20, 10, 180, -60, 180]]), (1, 2))
    save_trajectory(tmp_path / "p.npz", traj, station="default", robot="r1", speed_fraction=0.5)
    for fmt in FORMATS:
        out = tmp_path / "out" / f"p.{fmt}"
        assert main(["export", str(tmp_path / "p.npz"), "--format", fmt, "--out", str(out)], extensions=[]) == 0
        joints, _ = parse(out.read_text(), fmt)
        np.testing.assert_allclose(joints, traj.waypoints, atol=1e-6, rtol=0)
    assert main(["export", str(tmp_path / "missing.npz"), "--format", "csv"], extensions=[]) == 2
    assert "file not found" in capsys.readouterr().err
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    assert main(["export", str(tmp_path / "bad.npz"), "--format", "krl"], extensions=[]) == 2
    assert "not a saved trajectory" in capsys.readouterr().err


def test_animation_has_one_frame_per_sample_and_a_moving_time_cursor(tmp_path):
    """A short plan as an MP4: one frame at t = 0 and one per 1/fps s of motion, rendered above the measures
    strip whose red cursor moves right with time."""
    imageio = pytest.importorskip("imageio.v2")
    from dresspack_gym.io.animation import animate
    from dresspack_gym.io.loading import load_station
    from dresspack_gym.physics.simulation import CableSimulator

    station = Station(load_station("default"))
    home = station.home[0]
    traj = Trajectory(np.stack([home, home + np.radians([20, 0, 0, 0, 0, 0])]), (1,))
    fps = 5.0
    try:
        result = animate(CableSimulator(station), traj, tmp_path / "a.mp4", fps=fps, width=160, height=96,
                         strip_height=60)
    except Exception as exc:  # no offscreen GL on this machine
        if "rendering is unavailable" in str(exc):
            pytest.skip(str(exc))
        raise
    frames = [f for f in imageio.get_reader(tmp_path / "a.mp4")]
    duration = TimedPath.of(traj, station.config.robots[0].robot, station.config.simulation.speed_fraction).times[-1]
    assert len(frames) == result["frames"] == 1 + int(np.ceil(duration * fps - 1e-9))
    assert frames[0].shape == (96 + 60, 160, 3)

    def cursor(frame):  # column of the strongest red in the strip
        strip = frame[96:].astype(int)
        redness = (strip[..., 0] - strip[..., 1]).clip(0).sum(axis=0)
        return int(np.argmax(redness))

    cols = [cursor(f) for f in frames]
    assert cols[-1] > cols[0] + 60 and all(b >= a - 2 for a, b in zip(cols, cols[1:]))
    with pytest.raises(ConfigError, match="suffix"):
        animate(CableSimulator(station), traj, tmp_path / "a.avi")
