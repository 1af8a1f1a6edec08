"""The robustness map's engine choice (--physics dynamic|fast): validated, recorded in the map, never mixed on resume."""

import csv
import hashlib
import json
from dataclasses import asdict, replace

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import main
from dresspack_gym.io.loading import load_station
from dresspack_gym.maps.robustness.algorithm import RobustnessSettings
from dresspack_gym.maps.robustness.runner import _fingerprint, run_map
from dresspack_gym.robots.time_law import TIME_LAW

# A couple of configurations of the shipped small grid; no slowing down (the machinery, not the settings, is tested).
ARGS = ["robustness-map", "--grid", "small", "--station", "default", "--backend", "serial",
        "--max-dynamic-ratio", "1000", "--json"]


def test_a_bad_physics_value_is_refused_in_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(ARGS[:-1] + ["--out", str(tmp_path / "m"), "--physics", "quick"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--physics" in err and "'quick'" in err and "'dynamic'" in err and "'fast'" in err
    assert not (tmp_path / "m").exists()
    with pytest.raises(ConfigError, match="robustness.engine"):
        RobustnessSettings(engine="quick")


def test_a_fast_map_records_its_engine_and_refuses_another(tmp_path, capsys):
    out = tmp_path / "m"
    # the cable alone: no link to jam against at these unslowed excursions (the machinery is tested)
    assert main(ARGS + ["--out", str(out), "--physics", "fast", "--no-cable-robot-contact", "--limit", "2"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["engine"] == "fast" and summary["n_configs"] + summary["n_unconverged"] == 2
    assert summary["n_jammed"] == 0
    meta = json.loads((out / "meta.json").read_text())
    assert meta["engine"] == "fast" and meta["settings"]["engine"] == "fast" and not summary["cable_robot_contact"]
    with open(out / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["index"] for r in rows] == ["0", "1"] and all(r["jammed"] in ("0", "1") for r in rows)
    # resuming on MuJoCo is refused before anything runs, naming the field and both engines
    assert main(ARGS + ["--out", str(out), "--limit", "1", "--physics", "dynamic", "--no-cable-robot-contact"]) == 2
    error = json.loads(capsys.readouterr().out)
    assert error["field"] == "engine" and "'fast'" in error["error"] and "--physics dynamic" in error["error"]
    # ... and so is resuming with cable-robot contact on (the map was made with it off)
    assert main(ARGS + ["--out", str(out), "--limit", "1", "--physics", "fast", "--cable-robot-contact"]) == 2
    error = json.loads(capsys.readouterr().out)
    assert error["field"] == "cable_robot_contact" and "--no-cable-robot-contact" in error["error"]
    # ... and so is the other way round (through the API)
    dyn = tmp_path / "d"
    (dyn).mkdir()
    (dyn / "meta.json").write_text(json.dumps({"fingerprint": "0", "grid": "small", "station": "x", "settings": {}}))
    from dresspack_gym.io.loading import read_yaml
    from dresspack_gym.maps.robustness.grid import RobustnessGrid
    from dresspack_gym.shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped("small", "grids", "grid"), "grid"))
    with pytest.raises(ConfigError, match=r"engine.*'dynamic' engine, not on 'fast'"):
        run_map(grid, load_station("default"), dyn, RobustnessSettings(engine="fast"), backend="serial",
                progress=False)


def test_maps_default_to_mujoco_with_the_cable_alone(tmp_path):
    from dresspack_gym.physics.profiles import DEFAULT_ENGINE

    settings = RobustnessSettings()
    assert settings.engine == DEFAULT_ENGINE == "dynamic" and not settings.cable_robot_contact
    from dresspack_gym.cli.main import build_parser

    args = build_parser().parse_args(["robustness-map", "--grid", "small", "--station", "default", "--out",
                                      str(tmp_path)])
    assert args.physics == "dynamic" and args.cable_robot_contact is None  # None: the settings' default (off)


def test_mujoco_maps_made_before_engines_keep_their_fingerprint():
    from dresspack_gym.io.loading import read_yaml
    from dresspack_gym.maps.robustness.grid import RobustnessGrid
    from dresspack_gym.shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped("small", "grids", "grid"), "grid"))
    # a MuJoCo map's fingerprint leaves the engine out, as those maps were made before the engine was a setting
    dynamic = RobustnessSettings(engine="dynamic", cable_robot_contact=False)
    fields = asdict(dynamic)
    del fields["engine"]
    h = hashlib.sha256()
    for axis in (grid.ry, grid.j4, grid.j5, grid.j6):
        h.update(np.round(axis, 12).tobytes())
    h.update(b"s")
    h.update(json.dumps(fields, sort_keys=True, default=float).encode())
    h.update(TIME_LAW.encode())
    assert _fingerprint(grid, "s", dynamic) == h.hexdigest()[:16]
    assert _fingerprint(grid, "s", dynamic) != _fingerprint(grid, "s", replace(dynamic, engine="fast"))


@pytest.mark.slow  # one configuration at the folded wrist, its excursions redone slower (about a minute)
def test_the_folded_wrist_that_jammed_maps_without_a_jam():
    """thesis_24336's first configuration (Ry -225, j4 -180, j5 -110, j6 -180): its excursion folds j5 to its -130 deg
    limit, where the tool support enters the forearm's capsule; on the rod engine with contact on it maps without a
    jammed sample and every stored shape and motion step converged."""
    from dresspack_gym.io.loading import read_yaml
    from dresspack_gym.maps.robustness.algorithm import RobustnessEvaluator
    from dresspack_gym.maps.robustness.grid import RobustnessGrid
    from dresspack_gym.shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped("thesis_24336", "grids", "grid"), "grid"))
    ev = RobustnessEvaluator(load_station("default"), RobustnessSettings())
    r = ev.evaluate(0, grid.configurations()[0])
    assert not r.jammed and r.converged
    assert max(r.dev_neg, r.dev_pos) < 0.1  # robust, as in the map's row 0
