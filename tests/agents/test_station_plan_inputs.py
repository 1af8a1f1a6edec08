"""``dresspack station-plan`` on inputs it cannot plan: refused with the field named, nothing left behind, and an
interrupted run says what it saved and how to resume."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest
from dresspack.agents.planners.base import PlanningError
from dresspack.agents.stations import StationPlanConfig, StationPlanner
from helpers import NEAR_SIDE, near_side_yaml

from dresspack_gym.cli.main import main
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.stations.station import Station


def test_more_kept_options_than_costed_ones_is_refused_naming_the_field(tmp_path, capsys):
    """The solver's options are chosen among the costed ones: keeping more than are costed is a contradiction,
    refused before any work (and before any folder is made)."""
    with pytest.raises(ConfigError, match=r"^kept_options: 9 is more than costed_options \(2\).*1 to 2"):
        StationPlanConfig(kept_options=9, costed_options=2)
    StationPlanConfig(kept_options=2, costed_options=2)  # as many as are costed: fine
    out = tmp_path / "plans"
    code = main(["station-plan", "--station", "side_framing_4r", "--kept-options", "9", "--costed-options", "2",
                 "--out", str(out), "--json"])
    err = json.loads(capsys.readouterr().out)
    assert code == 2 and err["field"] == "kept_options" and "costed_options" in err["error"]
    assert not out.exists()


def test_a_station_whose_legs_cannot_be_planned_names_the_robot():
    """Robot r1 can reach its welds but no collision-free path leads there (every motion of it blocked): the error
    names the robot as its field, and its blocked moves, not an empty field."""
    cfg = load_station("side_framing_4r")
    station = Station(replace(cfg, robots=cfg.robots[:2],
                              weld_points=tuple(w for w in cfg.weld_points if w.name in NEAR_SIDE)))
    planner = StationPlanner(station, StationPlanConfig(kept_options=1, costed_options=1, cable_repairs=0, work=0.5,
                                                        iterations=50, exact_rounds=1, pair_solves=0,
                                                        fixed_assignment=True))
    planner.legs.planners[0].validity.segment_valid = lambda a, b: False  # r1 cannot move anywhere
    with pytest.raises(PlanningError) as error:
        planner.plan()
    assert error.value.field == "robots.r1"
    assert str(error.value).startswith("robots.r1: no assignment found") and "r1 Home -> r1_" in str(error.value)
    assert "r2 " not in str(error.value)  # r2's legs are planned: not named


def test_a_refused_run_leaves_no_output_folder(tmp_path, capsys, monkeypatch):
    """A weld no robot can reach is refused (naming it) before anything is written: neither the --out folder nor
    the default ./station_plans is left behind, empty."""
    far = {"name": "far_away", "robot": "r1", "pos": [20.0, 0.0, 1.0], "approach": [0, 0, -1]}
    station = near_side_yaml(tmp_path, extra=[far])
    out = tmp_path / "x"
    assert main(["station-plan", "--station", str(station), "--out", str(out), "--json"]) == 2
    assert json.loads(capsys.readouterr().out)["field"] == "weld_points.far_away"
    assert not out.exists()
    monkeypatch.chdir(tmp_path)
    assert main(["station-plan", "--station", str(station), "--json"]) == 2
    assert not (tmp_path / "station_plans").exists()


def test_an_interrupted_run_says_what_it_saved_and_how_to_resume(tmp_path, capsys, monkeypatch):
    """Ctrl-C while the solver rounds run (the options are costed and saved by then): one line on stderr,
    interrupted, what is saved, the command that resumes, and exit status 130 as the shell gives it."""
    station = near_side_yaml(tmp_path)
    out = tmp_path / "plans"

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(StationPlanner, "_rounds", interrupted)
    argv = ["station-plan", "--station", str(station), "--costed-options", "1", "--kept-options", "1", "--out",
            str(out)]
    try:
        code = main(argv)
    except KeyboardInterrupt:
        code = None
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 130
    assert err[-1] == (f"interrupted: saved option_costs.json in {out}; resume with: dresspack station-plan "
                       f"--station {station} --costed-options 1 --kept-options 1 --out {out}")
    assert (out / "option_costs.json").is_file()
