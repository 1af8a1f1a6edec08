"""Robustness mapping (Algorithm 1): grids, backends agree, resume never recomputes, query API, CLI."""

import csv
import json
from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import main
from dresspack_gym.io.loading import CONFIG_DIR, load_station, read_yaml
from dresspack_gym.maps.robustness.algorithm import RobustnessEvaluator, RobustnessSettings
from dresspack_gym.maps.robustness.grid import RobustnessGrid
from dresspack_gym.maps.robustness.runner import RobustnessMap, run_map

TINY = {"name": "tiny", "ry": {"start": 0, "stop": 0, "step": 1}, "j4": {"start": 0, "stop": 0, "step": 1},
        "j5": {"start": -60, "stop": 60, "step": 120}, "j6": {"start": 0, "stop": 90, "step": 90}}
# Tests of the machinery: no slowing down, on MuJoCo with the cable alone (the fast engine: test_robustness_engine)
FAST = RobustnessSettings(max_dynamic_ratio=100.0, engine="dynamic", cable_robot_contact=False)
MUJOCO = ["--physics", "dynamic", "--no-cable-robot-contact"]


def rows(out):
    with open(out / "results.csv") as f:
        return {int(r["index"]): r for r in csv.DictReader(f)}


@pytest.fixture(scope="module")
def station():
    return load_station("default")


def test_thesis_grids_have_the_thesis_sizes():
    a = RobustnessGrid.from_dict(read_yaml(CONFIG_DIR / "grids" / "thesis_24336.yaml"))
    b = RobustnessGrid.from_dict(read_yaml(CONFIG_DIR / "grids" / "thesis_67500.yaml"))
    assert len(a) == 24_336 and len(b) == 67_500
    assert np.degrees(a.ry[[0, -1]]).tolist() == pytest.approx([-225, 115])
    assert np.degrees(b.j5).min() > -110 and np.degrees(b.j5).max() < 110
    v = b.configurations()
    assert np.array_equal(b.nearest_index(v[[0, 1234, 67_499]]), [0, 1234, 67_499])


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_serial_and_process_backends_give_the_same_map(tmp_path, station):
    grid = RobustnessGrid.from_dict(TINY)
    s1 = run_map(grid, station, tmp_path / "serial", FAST, backend="serial", progress=False)
    s2 = run_map(grid, station, tmp_path / "proc", FAST, backend="process", workers=2, progress=False)
    a, b = rows(tmp_path / "serial"), rows(tmp_path / "proc")
    assert set(a) == set(range(4)) and {k: v["max_dev_m"] for k, v in a.items()} == {k: v["max_dev_m"] for k, v in b.items()}
    assert s1 == s2


def test_rerun_resumes_without_recomputing_and_survives_a_torn_line(tmp_path, station):
    grid = RobustnessGrid.from_dict(TINY)
    out = tmp_path / "map"
    run_map(grid, station, out, FAST, backend="serial", progress=False, limit=2)
    first = rows(out)
    assert len(first) == 2
    with open(out / "results.csv", "a") as f:
        f.write("3,0.0,0.0,60.0,9")  # an interrupted write: partial last line, no newline
    summary = run_map(grid, station, out, FAST, backend="serial", progress=False)
    after = rows(out)
    assert set(after) == set(range(4)) and summary["n_configs"] == 4
    for i, r in first.items():
        assert after[i] == r  # finished rows are kept as they were
    assert len(open(out / "results.csv").read().strip().splitlines()) == 5  # header + 4, no duplicates


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_rows_land_in_a_results_file_replaced_while_the_map_runs(tmp_path, station, monkeypatch):
    """A git checkout, stash or pull replaces results.csv with a new file (new inode); rows finished afterwards must
    land in that file, not in the replaced one (held open, they were silently lost)."""
    import os

    from dresspack_gym.maps.robustness import runner

    grid = RobustnessGrid.from_dict(TINY)
    out = tmp_path / "map"
    real = runner._iterate

    def replaced_after_first_unit(*args):
        for k, unit in enumerate(real(*args)):
            yield unit
            if k == 0:  # the first unit is written: replace the file as git does (write a copy, rename over)
                copy = out / "results.csv.tmp"
                copy.write_bytes((out / "results.csv").read_bytes())
                os.replace(copy, out / "results.csv")

    monkeypatch.setattr(runner, "_iterate", replaced_after_first_unit)
    run_map(grid, station, out, FAST, backend="serial", progress=False)
    assert set(rows(out)) == set(range(4))


@pytest.mark.slow  # about 15-20 s on 2 cores: the fast tier's time
def test_row_start_gives_the_same_rows_after_an_interruption_mid_row(tmp_path, station):
    # Each configuration of a row continues from the previous one, so a resumed half row is recomputed
    # from the row start: the results equal an uninterrupted run's.
    grid = RobustnessGrid.from_dict(TINY)
    assert FAST.start == "row"
    run_map(grid, station, tmp_path / "full", FAST, backend="serial", progress=False)
    run_map(grid, station, tmp_path / "cut", FAST, backend="serial", progress=False, limit=1)
    run_map(grid, station, tmp_path / "cut", FAST, backend="serial", progress=False, indices=[3])
    run_map(grid, station, tmp_path / "cut", FAST, backend="serial", progress=False)
    full, cut = rows(tmp_path / "full"), rows(tmp_path / "cut")
    assert {k: v["max_dev_m"] for k, v in full.items()} == {k: v["max_dev_m"] for k, v in cut.items()}


def test_a_different_grid_in_the_same_folder_is_refused(tmp_path, station):
    grid = RobustnessGrid.from_dict(TINY)
    run_map(grid, station, tmp_path, FAST, backend="serial", progress=False, limit=1)
    other = RobustnessGrid.from_dict(dict(TINY, j6={"start": 0, "stop": 30, "step": 30}))
    with pytest.raises(ConfigError) as e:
        run_map(other, station, tmp_path, FAST, backend="serial", progress=False)
    assert e.value.field == "out"


def test_query_api_uses_the_nearest_grid_configuration(tmp_path, station):
    grid = RobustnessGrid.from_dict(TINY)
    run_map(grid, station, tmp_path, FAST, backend="serial", progress=False)
    m = RobustnessMap(tmp_path, grid)
    v = grid.configurations()
    measured = np.array([float(rows(tmp_path)[i]["max_dev_m"]) < FAST.threshold for i in range(4)])
    np.testing.assert_array_equal(m.is_robust(v + np.radians(3.0)), measured)


def test_algorithm_is_deterministic_and_holds_the_nodes(station):
    ev = RobustnessEvaluator(station, FAST)
    v = np.radians([20.0, 40.0, 30.0, -60.0])
    assert ev.evaluate(5, v) == ev.evaluate(5, v)
    q = ev.joints(v)
    assert q[1] + q[2] == pytest.approx(v[0]) and np.allclose(q[3:], v[1:])


def test_ry_outside_the_arm_range_wraps_and_excursions_clip(station):
    ev = RobustnessEvaluator(station, FAST)
    q = ev.joints(np.radians([171.0, 0, 0, 0]))
    assert np.degrees(q[1] + q[2]) == pytest.approx(171.0 - 360.0)
    q = ev.joints(np.radians([0, 0, 210.0, 0]))
    assert np.degrees(q[4]) == pytest.approx(130.0)  # j5 limit


@pytest.mark.parametrize("ry", [153.0, 171.0, -225.0, 115.0])
def test_excursions_never_swing_link3_the_long_way_round(station, ry):
    """Ry near the ends of the arm's pitch range: the +-20 deg excursion moves link 3 by at most 20 deg
    (it used to wrap and sweep 340 deg the other way)."""
    ev = RobustnessEvaluator(station, FAST)
    v = np.radians([ry, 0.0, 0.0, 0.0])
    pitch = ev.joints(v)[1] + ev.joints(v)[2]
    for sign in (-1.0, 1.0):
        q = ev.joints(v, sign * np.asarray(FAST.excursion))
        assert abs(np.degrees(q[1] + q[2] - pitch)) <= 20.0 + 1e-6


def test_excursions_are_quasi_static_and_shapes_are_equilibria(station):
    """A too-fast excursion is redone slower until the cable's kinetic energy stays below the bound; the
    stored shapes are converged equilibria."""
    strict = RobustnessSettings(speed_fraction=1.0, max_dynamic_ratio=1e-6, min_speed_fraction=0.25, engine="dynamic",
                                cable_robot_contact=False)
    ev = RobustnessEvaluator(station, strict)
    r = ev.evaluate(0, np.radians([20.0, 40.0, 30.0, -60.0]))
    assert r.speed_fraction < strict.speed_fraction  # rated speed swings the cable: it slowed down
    loose = RobustnessEvaluator(station, replace(FAST, speed_fraction=1.0)).evaluate(
        0, np.radians([20.0, 40.0, 30.0, -60.0]))
    assert loose.speed_fraction == 1.0 and loose.dynamic_ratio > r.dynamic_ratio
    assert r.converged and loose.converged


def test_cable_robot_contact_is_an_explicit_option(station):
    off = RobustnessEvaluator(station, FAST)
    on = RobustnessEvaluator(station, replace(FAST, cable_robot_contact=True))
    assert not off.station.config.robots[0].dresspack.collide_with_robot
    assert on.station.config.robots[0].dresspack.collide_with_robot


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_cli_json_summary(tmp_path, capsys):
    grid = tmp_path / "tiny.yaml"
    import yaml

    grid.write_text(yaml.safe_dump(TINY))
    assert main(["robustness-map", "--grid", str(grid), "--station", "default", "--out", str(tmp_path / "o"),
                 "--backend", "serial", "--max-dynamic-ratio", "100", "--json", *MUJOCO]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"n_configs", "n_non_robust", "fraction_non_robust", "per_ry", "n_unconverged"} <= set(out)
    assert out["n_configs"] == 4
    assert (tmp_path / "o" / "non_robust_over_ry.png").is_file()


def test_cli_resolves_shipped_grid_names_and_rejects_unknown_ones(tmp_path, capsys):
    assert main(["robustness-map", "--grid", "no_such_grid", "--station", "default", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "grid" in err and "thesis_67500" in err


@pytest.mark.slow  # Ray's start-up dominates (about 2 min); the process backend's equality test stays in the suite
def test_ray_backend_gives_the_same_map_as_serial(tmp_path, station):
    ray = pytest.importorskip("ray")
    grid = RobustnessGrid.from_dict(TINY)
    run_map(grid, station, tmp_path / "serial", FAST, backend="serial", progress=False, limit=2)
    try:
        run_map(grid, station, tmp_path / "ray", FAST, backend="ray", workers=2, progress=False, limit=2)
    finally:
        ray.shutdown()
    a, b = rows(tmp_path / "serial"), rows(tmp_path / "ray")
    assert set(a) == {0, 1} and {k: v["max_dev_m"] for k, v in a.items()} == {k: v["max_dev_m"] for k, v in b.items()}


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_path_comparison_reports_consistent_counts(tmp_path, station):
    from dresspack_gym.maps.robustness.paths import compare_paths

    grid = RobustnessGrid.from_dict(TINY)
    rep = compare_paths(grid, station, tmp_path, FAST, k_paths=2, n_sample=2, seed=1, backend="serial",
                        progress=False)
    assert rep["n_compared"] == 2
    assert rep["both_robust"] + rep["both_non_robust"] + rep["only_k_path_non_robust"] \
        + rep["only_two_path_non_robust"] == 2
    agree = (rep["both_robust"] + rep["both_non_robust"]) / 2
    assert rep["agreement"] == pytest.approx(agree)
    assert len(rows(tmp_path / "two_path")) == 2 and len(rows(tmp_path / "k_path")) == 2
    assert json.loads((tmp_path / "paths_report.json").read_text())["agreement"] == rep["agreement"]
    with pytest.raises(ConfigError, match="sample"):
        compare_paths(grid, station, tmp_path / "x", FAST, k_paths=2, n_sample=99)


def test_cli_robustness_paths_json(tmp_path, capsys):
    import yaml

    grid = tmp_path / "tiny.yaml"
    grid.write_text(yaml.safe_dump(TINY))
    assert main(["robustness-paths", "--grid", str(grid), "--station", "default", "--out", str(tmp_path / "p"),
                 "--k-paths", "2", "--sample", "1", "--backend", "serial", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_compared"] == 1 and 0.0 <= out["agreement"] <= 1.0


def test_an_attempt_redone_slower_stops_early_with_the_same_result(station, monkeypatch):
    """An attempt whose excursion exceeds the ratio bound is redone at half speed whatever follows, so it stops at
    that excursion: the result equals that of every attempt run to its end, in fewer moves."""
    strict = replace(FAST, speed_fraction=1.0, max_dynamic_ratio=1e-6, min_speed_fraction=0.25)
    v = np.radians([20.0, 40.0, 30.0, -60.0])
    moves = []

    def counted(ev):
        go = ev._go
        ev._go = lambda *a: (moves.append(1), go(*a))[1]
        return ev

    early = counted(RobustnessEvaluator(station, strict)).evaluate(0, v)
    n_early = len(moves)
    full = RobustnessEvaluator(station, strict)
    paths = full._paths
    monkeypatch.setattr(full, "_paths", lambda index, v, speed, stop_above=None: paths(index, v, speed))
    assert counted(full).evaluate(0, v) == early
    assert early.speed_fraction == 0.25 and n_early < len(moves) - n_early
