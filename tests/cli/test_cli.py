"""The dresspack command line: inspect (text and JSON), render, bench, and error exits."""

import json
import subprocess
import sys

import numpy as np
import pytest

from dresspack_gym.cli.main import main


def test_inspect_json_has_the_documented_keys(capsys):
    assert main(["inspect", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("max_curvature", "max_tension", "min_clearance", "max_twist_rate", "cost", "cost_terms"):
        assert key in out
    assert set(out["cost_terms"]) == {"curvature", "tension", "distance", "twist", "damage"}
    assert out["cost"] == pytest.approx(sum(out["cost_terms"].values()))
    assert all(np.isfinite([out["max_curvature"], out["max_tension"], out["min_clearance"], out["cost"]]))


def test_inspect_text_summarises_robot_cable_and_measures(capsys):
    assert main(["inspect", "--station", "default"]) == 0
    out = capsys.readouterr().out
    for text in ("abb_irb6700_200_260", "young=", "max curvature", "wear cost (4.10)", "IK solutions"):
        assert text in out


def test_inspect_reports_bad_station_cleanly(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nrobots: []\n")
    assert main(["inspect", "--station", str(bad)]) == 2
    assert "robots" in capsys.readouterr().err


def test_render_writes_a_picture(tmp_path):
    out = tmp_path / "station.png"
    assert main(["render", "--out", str(out), "--width", "320", "--height", "240"]) == 0
    import matplotlib.image as mpimg

    img = mpimg.imread(out)
    assert img.shape[:2] == (240, 320)
    assert img[..., :3].std() > 0.05  # not a blank frame


def test_bench_physics_json(capsys):
    assert main(["bench", "physics", "--json", "--repeats", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["raw_mj_step_steps_per_s"] > 0 and out["move90_steps"] > 0
    assert out["engine"] == "dynamic" and out["replay_wall_per_motion_s"] > 0


def test_bench_physics_on_the_rod_engine_json(capsys):
    """Both engines report the same replay field over the same weld cycles, so they compare by it."""
    assert main(["bench", "physics", "--physics", "fast", "--json", "--repeats", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["engine"] == "fast" and out["replay_wall_per_motion_s"] > 0 and out["replay_paths"] == 5
    assert out["settle_converged"] and out["equilibria_per_s"] > 0 and out["sample_solve_us"] > 0
    # MuJoCo's replay of the same cycles in the same run, and the ratio the speed bar is stated by
    assert out["dynamic_replay_wall_per_motion_s"] > 0
    assert out["replay_speedup_vs_dynamic"] == pytest.approx(
        out["dynamic_replay_wall_per_motion_s"] / out["replay_wall_per_motion_s"], rel=0.02)


@pytest.mark.slow
def test_bench_physics_at_other_segments(capsys):
    """--segments sets the measured engine's resolution; MuJoCo's comparison replay keeps the station's own."""
    assert main(["bench", "physics", "--physics", "fast", "--segments", "12", "--json", "--repeats", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cable_segments"] == [12] and out["dynamic_segments"] != [12]
    assert main(["bench", "collision", "--segments", "12"]) == 2
    assert "--segments" in capsys.readouterr().err


def test_only_bench_physics_chooses_the_engine(capsys):
    assert main(["bench", "restrictions", "--physics", "fast", "--repeats", "1"]) == 2
    err = capsys.readouterr().err
    assert "--physics" in err and "bench physics" in err and "Traceback" not in err


def test_console_script_module_entry():
    res = subprocess.run([sys.executable, "-m", "dresspack_gym.cli.main", "--help"], capture_output=True, text=True)
    assert res.returncode == 0 and "inspect" in res.stdout


def test_restrictions_command_lists_rules_and_plots(tmp_path, capsys):
    out = tmp_path / "zones.png"
    assert main(["restrictions", "--station", "default", "--plot", str(out)]) == 0
    text = capsys.readouterr().out
    assert "support cylinder" in text and "forbidden" in text
    assert out.stat().st_size > 10_000


def test_bench_restrictions_json(capsys):
    assert main(["bench", "restrictions", "--json", "--repeats", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert 0 < out["batched_us_per_config"] < out["single_call_us"]


def test_bench_collision_json(capsys):
    assert main(["bench", "collision", "--json", "--repeats", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    # a compiled query poses only this robot's bodies, so it may cost less than MuJoCo's whole kinematics pass: the
    # ratios are timings, which a loaded machine can swap, so only their being measured is checked
    assert out["pairs"] > 0 and out["kinematics_us"] > 0
    assert out["pose_and_bounds_vs_kinematics"] > 0.0 and out["min_distance_vs_kinematics"] > 0.0
    assert 0.0 < out["collides_fraction"] < 1.0
