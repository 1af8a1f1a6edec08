"""A robot program is written only for a plan that cannot hurt the robot: its waypoints, interpolated points,
speeds, accelerations and jerks within the robot's limits, and the plan made for the robot and station named.
Every refusal names the waypoint (or move), the joint and the value."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import main
from dresspack_gym.io import program_checks
from dresspack_gym.io.loading import load_station
from dresspack_gym.io.programs import FORMATS, parse
from dresspack_gym.physics.trajectory import Trajectory, load_trajectory_file, plan_fingerprint, save_trajectory


@pytest.fixture(scope="module")
def default_cfg():
    return load_station("default")


def _export(*args) -> int:
    return main(["export", *map(str, args)], extensions=[])


def _plan(cfg, waypoints, path, fingerprint=True, **meta):
    traj = Trajectory(np.asarray(waypoints, dtype=float), tuple(range(1, len(waypoints))))
    meta = {"station": "default", "robot": "r1", "speed_fraction": 0.5, **meta}
    if fingerprint:
        meta["fingerprint"] = plan_fingerprint(cfg, 0)
    save_trajectory(path, traj, **meta)
    return traj


def test_a_waypoint_beyond_a_joint_limit_is_refused_naming_waypoint_joint_and_value(default_cfg, tmp_path, capsys):
    home = default_cfg.robots[0].home
    bad = home.copy()
    bad[1] = 3.0  # rad: 171.89 deg, the robot's j2 stops at 85 deg
    _plan(default_cfg, [home, bad, home], tmp_path / "p.npz")
    assert _export(tmp_path / "p.npz", "--format", "rapid", "--out", tmp_path / "p.mod") == 2
    err = capsys.readouterr().err
    assert "plan.waypoints[1][1]" in err and "171.8873 deg" in err and "joint 2's limits [-65, 85]" in err
    assert not (tmp_path / "p.mod").exists()


def test_a_plan_made_on_one_station_is_refused_on_another(default_cfg, tmp_path, capsys):
    home = default_cfg.robots[0].home
    for fingerprint in (True, False):  # stored, or computed from the station the plan names
        _plan(default_cfg, [home, home + np.radians([10, 0, 0, 0, 0, 0])], tmp_path / "p.npz", fingerprint)
        for cmd in ("export", "animate"):
            extra = ["--format", "krl"] if cmd == "export" else ["--out", tmp_path / "a.gif"]
            rc = main([cmd, str(tmp_path / "p.npz"), "--station", "side_framing_4r", *map(str, extra)], extensions=[])
            err = capsys.readouterr().err
            assert rc == 2 and "made for robot 'r1' of station 'stud_welding_default'" in err, err
            assert "not for robot 'r1' of station 'side_framing_4r'" in err
    # the same plan on its own station exports
    assert _export(tmp_path / "p.npz", "--format", "krl") == 0


def test_a_plan_naming_no_station_needs_one_named(default_cfg, tmp_path, capsys):
    home = default_cfg.robots[0].home
    np.savez(tmp_path / "eval.npz", waypoints=np.stack([home, home + 0.1]), stops=np.array([1]))
    assert _export(tmp_path / "eval.npz", "--format", "csv") == 2
    assert "--station" in capsys.readouterr().err
    assert _export(tmp_path / "eval.npz", "--format", "csv", "--station", "default", "--dry-run") == 0
    assert "taken for the station and robot named on the command line" in capsys.readouterr().out


def test_a_truncated_plan_file_is_refused_without_a_traceback(default_cfg, tmp_path, capsys):
    home = default_cfg.robots[0].home
    _plan(default_cfg, [home, home + 0.1], tmp_path / "p.npz")
    data = (tmp_path / "p.npz").read_bytes()
    for cut in (len(data) // 3, len(data) - 10):
        (tmp_path / "cut.npz").write_bytes(data[:cut])
        with pytest.raises(ConfigError) as err:
            load_trajectory_file(tmp_path / "cut.npz")
        assert err.value.field == "plan"
        assert _export(tmp_path / "cut.npz", "--format", "json") == 2
        assert "not a saved trajectory" in capsys.readouterr().err


def test_a_speed_above_the_rated_is_refused(default_cfg, tmp_path, capsys):
    home = default_cfg.robots[0].home
    _plan(default_cfg, [home, home + np.radians([40, 0, 0, 0, 0, 0])], tmp_path / "p.npz", speed_fraction=1.5)
    assert _export(tmp_path / "p.npz", "--format", "rapid") == 2
    assert "speed_fraction: 1.5 is not in (0, 1]" in capsys.readouterr().err


@pytest.mark.parametrize("kind,limit", [("peak_rate", "velocity"), ("peak_acceleration", "acceleration"),
                                        ("peak_jerk", "jerk")])
def test_a_time_law_beyond_a_rated_limit_is_refused(default_cfg, monkeypatch, kind, limit):
    """The checks measure the timed motion itself: a time law that drove a joint 1 % beyond its rated speed,
    acceleration or jerk would be refused, not written."""
    honest = getattr(program_checks.SegmentMotion, kind).fget

    class Overdriven(program_checks.SegmentMotion):
        pass

    setattr(Overdriven, kind, property(lambda self: honest(self) * 1.01))
    monkeypatch.setattr(program_checks, "SegmentMotion", Overdriven)
    home = default_cfg.robots[0].home
    traj = Trajectory(np.stack([home, home + np.radians([40, 0, 0, 0, 0, 0])]), (1,))
    with pytest.raises(ConfigError, match=f"above its {limit} limit") as err:
        program_checks.check_program(traj, default_cfg.robots[0].robot, 1.0)
    assert err.value.field == "plan.segments[0][0]"


def test_dry_run_prints_the_margins_and_writes_nothing(default_cfg, tmp_path, capsys):
    home = default_cfg.robots[0].home
    _plan(default_cfg, [home, home + np.radians([20, 5, 0, 30, 0, 0]), home], tmp_path / "p.npz")
    assert _export(tmp_path / "p.npz", "--format", "rapid", "--out", tmp_path / "p.mod", "--dry-run", "--json") == 0
    summary = json.loads(capsys.readouterr().out)
    assert not (tmp_path / "p.mod").exists()
    limits = np.degrees(np.array(default_cfg.robots[0].robot.joint_limits_rad))
    q = np.degrees(np.stack([home, home + np.radians([20, 5, 0, 30, 0, 0])]))
    assert summary["limit_margin_deg"] == pytest.approx(np.minimum(q - limits[:, 0], limits[:, 1] - q).min())
    assert summary["peak_velocity_of_limit"]["ratio"] == pytest.approx(0.5)  # the slowest joint at 0.5 x rated
    assert summary["identity"] == "fingerprint stored in the plan matches"
    assert summary["cycle_time_s"] > 0 and summary["interpolated_points_checked"] > 2


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_random_plans_export_and_parse_back_and_random_violations_are_refused(default_cfg, tmp_path, capsys):
    """Property: 24 random plans within the limits export in every format and parse back within 1e-6 rad and
    1e-6 s; each with one random violation (a joint beyond a limit, a speed beyond the rated, another station)
    is refused, naming what was violated."""
    rng = np.random.default_rng(56)
    model = default_cfg.robots[0].robot
    limits = np.array(model.joint_limits_rad)
    span = limits[:, 1] - limits[:, 0]
    for case in range(24):
        k = int(rng.integers(2, 6))
        q = limits[:, 0] + span * rng.uniform(0.02, 0.98, size=(k, 6))
        fraction = float(rng.uniform(0.1, 1.0))
        traj = _plan(default_cfg, q, tmp_path / "ok.npz", speed_fraction=fraction)
        for fmt in FORMATS:
            out = tmp_path / f"ok.{fmt}"
            assert _export(tmp_path / "ok.npz", "--format", fmt, "--out", out) == 0, capsys.readouterr().err
            joints, times = parse(out.read_text(), fmt)
            np.testing.assert_allclose(model.from_controller(joints), traj.waypoints, atol=1e-6, rtol=0)
            if times is not None:
                need = [program_checks.SegmentMotion(d, model.joint_motion_limits.at_speed(fraction)).duration
                        for d in np.diff(traj.waypoints, axis=0)]
                np.testing.assert_allclose(np.diff(times), need, atol=1e-6, rtol=0)
        capsys.readouterr()
        violation = ("joint", "speed", "station")[case % 3]
        bad_q, meta, station = q.copy(), {"speed_fraction": fraction}, []
        w, j = int(rng.integers(0, k)), int(rng.integers(0, 6))
        if violation == "joint":
            side = int(rng.integers(0, 2))
            bad_q[w, j] = limits[j, side] + (1 if side else -1) * float(rng.uniform(1e-6, 1.0))
            expect = f"plan.waypoints[{w}][{j}]"
        elif violation == "speed":
            meta["speed_fraction"] = float(rng.uniform(1.001, 3.0))
            expect = "speed_fraction"
        else:
            station = ["--station", "side_framing_4r"]
            expect = "not for robot 'r1' of station 'side_framing_4r'"
        _plan(default_cfg, bad_q, tmp_path / "bad.npz", **meta)
        assert _export(tmp_path / "bad.npz", "--format", FORMATS[case % 4], "--out", tmp_path / "bad.out",
                       *station) == 2
        assert expect in capsys.readouterr().err
        assert not (tmp_path / "bad.out").exists()


def test_a_plan_saved_by_dresspack_plan_carries_its_fingerprint(tmp_path, capsys):
    pytest.importorskip("ompl")
    out = tmp_path / "p.npz"
    assert main(["plan", "--station", "default", "--planner", "ompl", "--iterations", "300", "--welds",
                 "b_pillar_outer", "--out", str(out)]) == 0
    _, meta = load_trajectory_file(out)
    assert meta["fingerprint"] == plan_fingerprint(load_station("default"), 0)
    capsys.readouterr()
    assert _export(out, "--format", "krl", "--dry-run") == 0
    assert "fingerprint stored in the plan matches" in capsys.readouterr().out
