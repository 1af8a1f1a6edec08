"""An evaluation spread over processes gives the rows of one process (but for wall-clock times), in spec order."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("ompl")
pytest.importorskip("sb3_contrib")

from dresspack_gym.cli.main import main  # noqa: E402

WALL_CLOCK = ("planning_time", "inference_time")
ARGS = ["eval", "--planners", "ppo", "ompl", "--welds", "roof_rail_top", "--seeds", "0", "1", "--json", "--no-render"]


def _results(out) -> list[dict]:
    return json.loads((out / "results.json").read_text())["rows"]


@pytest.mark.slow  # an evaluation run twice, once on two processes (~15 s)
def test_two_processes_give_the_rows_of_one(tmp_path, capsys):
    one, two = tmp_path / "one", tmp_path / "two"
    assert main([*ARGS, "--jobs", "1", "--out", str(one)]) == 0
    assert main([*ARGS, "--jobs", "2", "--out", str(two)]) == 0
    rows_one, rows_two = _results(one), _results(two)
    keys = [f"{m}|roof_rail_top|{s}" for m in ("ppo", "ompl") for s in (0, 1)]
    assert [r["key"] for r in rows_one] == [r["key"] for r in rows_two] == keys  # spec order, not finish order
    assert all(r["success"] for r in rows_one)  # rows with measures to compare, not failures alike
    for a, b in zip(rows_one, rows_two):
        assert set(a) == set(b)
        assert {k: v for k, v in a.items() if k not in WALL_CLOCK} == {k: v for k, v in b.items()
                                                                       if k not in WALL_CLOCK}, a["key"]
    for path in sorted((one / "trajectories").glob("*.npz")):
        saved_one, saved_two = np.load(path), np.load(two / "trajectories" / path.name)
        assert np.array_equal(saved_one["waypoints"], saved_two["waypoints"]), path.name
    assert len((two / "results.jsonl").read_text().splitlines()) == len(keys)
    capsys.readouterr()


def test_jobs_is_checked_naming_the_flag(capsys):
    for bad in ("0", "-1", "65", "two"):
        assert main([*ARGS, "--jobs", bad]) == 2  # under --json: one JSON error object
        assert json.loads(capsys.readouterr().out)["field"] == "--jobs"
